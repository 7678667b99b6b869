//! The candidates' table, as CSV and Markdown (fit.csv, fit.md).

use super::*;

pub(super) fn tables(rows: &[Row], bits: Scheme) -> (String, String) {
    let bits = bits.bits();
    let mut csv = String::from(
        "name,macs_per_sample,steps,psnr_f32,psnr_fixed,us_per_ray,samples_per_ray,model_bytes,cost_per_sample,coarse_samples,gave_up\n",
    );
    let mut md = format!(
        "| candidate | coarse samples | MAC/sample | cost/sample | steps | PSNR f32 | PSNR int{bits} | µs/ray (int{bits}, 1 core) | samples/ray | bytes | to fit --max-bytes |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n"
    );
    for r in rows {
        csv += &format!(
            "{},{},{},{:.3},{:.3},{:.2},{:.2},{},{},{},{}\n",
            r.name,
            r.macs,
            r.steps,
            r.psnr_f32,
            r.psnr_fixed,
            r.us_per_ray,
            r.samples_per_ray,
            r.bytes,
            r.cost,
            r.coarse,
            r.gave_up
        );
        md += &format!(
            "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.1} | {:.1} | {} | {} |\n",
            r.name,
            r.coarse,
            r.macs,
            r.cost,
            r.steps,
            r.psnr_f32,
            r.psnr_fixed,
            r.us_per_ray,
            r.samples_per_ray,
            r.bytes,
            r.gave_up
        );
    }
    (csv, md)
}
