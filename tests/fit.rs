//! `nerf fit` on tiny data: the model a byte budget or a PSNR target
//! keeps, and the table of what it tried.

mod support;

use support::cli::{blender_scene, fails, ok, s, tmp};

#[test]
fn fit_within_a_byte_budget_keeps_the_most_accurate_model_that_fits_and_says_what_it_gave_up() {
    let d = tmp("fit-bytes");
    let data = blender_scene(&d, 16, 6);
    let run = d.join("fit");
    let max = 40_000;
    let out = ok(&["fit", "--data", s(&data), "--max-bytes", &max.to_string(), "--minutes", "0.002", "--out", s(&run)]);
    // a 64³ occupancy grid alone is 32 KiB: the wider candidates coarsen it, the feature grid shrinks its table
    assert!(out.contains("after giving up occupancy grid 64^3 -> 32^3"), "{out}");
    assert!(out.contains("feature table 2^15 -> 2^"), "{out}");
    assert!(out.contains("fit: not training 6x96: it does not fit --max-bytes 40000"), "{out}");
    let csv = std::fs::read_to_string(run.join("fit.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    // the seven candidates but 6x96
    assert_eq!(rows.len(), 6, "every candidate that fits, once (no sample search without a target): {csv}");
    assert!(rows.iter().all(|r| r[7].parse::<usize>().unwrap() <= max), "{csv}");
    let best = rows.iter().max_by(|a, b| a[4].parse::<f64>().unwrap().total_cmp(&b[4].parse().unwrap())).unwrap();
    assert!(out.contains(&format!("fit: chose {} at", best[0])), "the most accurate: {out}\n{csv}");
    let fixed = std::fs::read(run.join("model_fixed.nerf")).unwrap();
    assert!(fixed.len() <= max, "{} bytes", fixed.len());
    // a budget nothing fits: one line, and no model
    let e =
        fails(&["fit", "--data", s(&data), "--max-bytes", "2000", "--minutes", "0.002", "--out", s(&d.join("none"))]);
    assert!(e.contains("no candidate fits --max-bytes 2000"), "{e}");
}

#[test]
fn fit_keeps_the_cheapest_candidate_that_reaches_the_target_and_tables_what_it_tried() {
    let d = tmp("fit");
    let data = blender_scene(&d, 16, 6);
    let run = d.join("fit");
    let out = ok(&["fit", "--data", s(&data), "--target-psnr", "8", "--minutes", "0.01", "--out", s(&run)]);
    assert!(out.contains("| candidate |") && out.contains("fit: chose 2x32-noview"), "{out}");
    // the next candidate would cost more per ray even at a third of its samples
    assert!(out.contains("fit: not training 3x32"), "{out}");
    let csv = std::fs::read_to_string(run.join("fit.csv")).unwrap();
    // the chosen candidate at its trained samples per ray, then at fewer
    // while it still reaches the target (and the first that does not)
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert!(rows.len() >= 2 && rows.iter().all(|r| r[0] == "2x32-noview"), "{csv}");
    let coarse: Vec<u16> = rows.iter().map(|r| r[9].parse().unwrap()).collect();
    assert!(coarse.windows(2).all(|w| w[0] > w[1]) && coarse[0] == 192, "{csv}");
    let reached: Vec<bool> = rows.iter().map(|r| r[4].parse::<f64>().unwrap() >= 8.0).collect();
    let kept = reached.iter().take_while(|&&r| r).count();
    assert!(kept >= 1 && (kept == rows.len() || kept == rows.len() - 1), "{csv}");
    let fixed = std::fs::read(run.join("model_fixed.nerf")).unwrap();
    let m = nerf_infer::Model::from_bytes(&fixed).unwrap();
    assert_eq!(m.scheme(), nerf_infer::Scheme::I8);
    assert!(m.grid.is_some() && m.fine.is_none());
    assert_eq!(m.samples.coarse, coarse[kept - 1], "the fewest samples that reached the target: {csv}");
    assert!(run.join("model.nerf").is_file() && run.join("2x32-noview/train.jsonl").is_file());
    // an unreachable target: every candidate tried, cheapest first, and a
    // one-line error naming the table
    let run = d.join("fit-miss");
    let o =
        support::cli::nerf(&["fit", "--data", s(&data), "--target-psnr", "99", "--minutes", "0.002", "--out", s(&run)]);
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success());
    assert!(err.trim_end().lines().last().unwrap().starts_with("error: no candidate reached 99.00 dB"), "{err}");
    let csv = std::fs::read_to_string(run.join("fit.csv")).unwrap();
    let cost: Vec<usize> = csv.lines().skip(1).map(|l| l.split(',').nth(8).unwrap().parse().unwrap()).collect();
    assert_eq!(cost.len(), 7, "{csv}");
    assert!(cost.windows(2).all(|w| w[0] < w[1]), "not cheapest first: {cost:?}");
    assert!(csv.contains("\nfeatures,"), "the feature-grid candidate was not tried: {csv}");
    assert!(csv.contains("\nfeatures-2x32,"), "the narrow feature-grid candidate was not tried: {csv}");
    assert!(!run.join("model.nerf").exists());
}
