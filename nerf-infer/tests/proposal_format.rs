//! A model with a proposal grid (the golden int8 one, `tests/data/`) reads
//! back byte for byte, and grids or sample counts the march cannot hold are
//! refused by the model writer and the renderer.
#![cfg(feature = "alloc")]

use nerf_infer::format::owned::OwnedModel;
use nerf_infer::{Model, RenderOptions, RendererFixed};

const BLOB: &[u8] = include_bytes!("data/golden8_proposal.nerf");

#[test]
fn proposal_models_read_back_byte_for_byte_and_refuse_bad_grids() {
    let m = Model::from_bytes(BLOB).unwrap();
    assert!(m.proposal.is_some());
    let owned = OwnedModel::from_model(&m);
    assert_eq!(owned.to_bytes().unwrap(), BLOB);
    // a grid whose codes do not fill res³, or whose top code's density is not finite, is refused
    let mut short = owned.clone();
    short.proposal.as_mut().unwrap().1.pop();
    assert!(short.to_bytes().is_err());
    let mut huge = owned.clone();
    huge.proposal.as_mut().unwrap().0.log_step = 1.0;
    assert!(huge.to_bytes().is_err());
    // importance samples beyond the fine buffer, and a fine network beside the grid, are refused
    let mut many = owned.clone();
    many.samples.fine = 256;
    assert!(many.to_bytes().is_err());
    let mut two_pass = owned.clone();
    two_pass.fine = Some(owned.coarse.clone());
    assert!(two_pass.to_bytes().is_err());
    assert!(RendererFixed::new(&m, RenderOptions { fine: 256, ..RenderOptions::from_model(&m) }).is_err());
}
