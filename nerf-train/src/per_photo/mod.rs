//! What a run learns for each training photo: its colour correction
//! ([`appearance`]) and its pose correction ([`pose`]).

pub mod appearance;
pub mod pose;
