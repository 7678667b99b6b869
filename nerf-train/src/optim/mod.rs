//! The optimiser: [`adam`] over the network's layers and the feature
//! grid's table (the parameters' moving average is folded into its sweep).

pub mod adam;
