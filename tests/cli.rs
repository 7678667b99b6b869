//! The `nerf` binary end to end, as a user runs it, on tiny data.

mod support;

use nerf_train::config::TrainConfig;
use support::cli::{blender_scene, fails, ok, s, tmp};

#[test]
fn scene_train_resume_eval_export_info_render() {
    let d = tmp("e2e");
    let data = blender_scene(&d, 16, 6);
    let cfg = d.join("tiny.json");
    std::fs::write(
        &cfg,
        r#"{"depth": 2, "width": 16, "view_width": 8, "pos_freqs": 4, "n_coarse": 8, "n_fine": 8, "batch_rays": 64}"#,
    )
    .unwrap();
    let run = d.join("run");
    ok(&[
        "train",
        "--data",
        s(&data),
        "--preset",
        "fast",
        "--config",
        s(&cfg),
        "--iters",
        "12",
        "--out",
        s(&run),
        "--val-secs",
        "0",
        "--val-views",
        "1",
        "--log-every",
        "4",
    ]);
    for f in ["model.nerf", "checkpoint.bin", "train.jsonl"] {
        assert!(run.join(f).is_file(), "{f} missing");
    }
    ok(&[
        "train",
        "--data",
        s(&data),
        "--iters",
        "20",
        "--out",
        s(&run),
        "--resume",
        "--val-views",
        "0",
        "--log-every",
        "4",
    ]);
    let log = std::fs::read_to_string(run.join("train.jsonl")).unwrap();
    let last: serde_json::Value = serde_json::from_str(log.lines().last().unwrap()).unwrap();
    assert_eq!(last["step"], 20);
    assert!(log.lines().any(|l| l.contains("\"val_psnr\":") && !l.contains("\"val_psnr\":null")));

    let model = run.join("model.nerf");
    let report: serde_json::Value = serde_json::from_str(&ok(&[
        "eval",
        s(&model),
        "--data",
        s(&data),
        "--split",
        "test",
        "--threads",
        "1",
        "--save",
        s(&d.join("ev")),
    ]))
    .unwrap();
    for key in ["psnr", "ssim", "views", "us_per_ray", "samples_per_ray", "model_bytes"] {
        assert!(!report[key].is_null(), "{key} missing from {report}");
    }
    assert_eq!(report["views"].as_array().unwrap().len(), 6);
    // 8 coarse + (8 + 8) fine per ray that meets the scene bounds, 0 for the others
    let spr = report["samples_per_ray"].as_f64().unwrap();
    assert!(spr > 8.0 && spr <= 24.0, "{spr}");
    assert!(d.join("ev/r_0.png").is_file() && d.join("ev/r_0_gt.png").is_file());

    for (bits, act) in [("16", "16"), ("8", "16"), ("8", "8")] {
        let out = d.join(format!("m{bits}a{act}.nerf"));
        ok(&["export", s(&model), "--bits", bits, "--act-bits", act, "--out", s(&out)]);
        let info: serde_json::Value = serde_json::from_str(&ok(&["info", s(&out), "--json"])).unwrap();
        assert_eq!(info["scheme"], if bits == "16" { "I16" } else { "I8" });
        assert_eq!(info["coarse"]["activation_bits"].to_string(), act, "{info}");
        let r: serde_json::Value =
            serde_json::from_str(&ok(&["eval", s(&out), "--data", s(&data), "--split", "test"])).unwrap();
        // the export renders the f32 model's pictures: a wrong image moves its PSNR by more
        let (q, f) = (r["psnr"].as_f64().unwrap(), report["psnr"].as_f64().unwrap());
        assert!((q - f).abs() < 0.05, "--bits {bits} --act-bits {act}: {q} dB, the f32 model {f} dB");
    }
    assert!(ok(&["info", s(&model)]).contains("numeric scheme: F32"));
    let e = fails(&["export", s(&model), "--bits", "16", "--act-bits", "8", "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains("--act-bits 8 needs --bits 8"), "{e}");
    assert!(!d.join("x.nerf").exists());
    // every layer narrowed to int8 precision in an int16 model: the int8
    // model's pixels; one layer: between the two
    let info: serde_json::Value = serde_json::from_str(&ok(&["info", s(&model), "--json"])).unwrap();
    let n = info["coarse"]["layers"].as_array().unwrap().len();
    let all: Vec<String> = (0..n).map(|i| i.to_string()).collect();
    let psnr_of = |m: &std::path::Path| -> f64 {
        let r: serde_json::Value =
            serde_json::from_str(&ok(&["eval", s(m), "--data", s(&data), "--split", "test"])).unwrap();
        r["psnr"].as_f64().unwrap()
    };
    let narrow = d.join("narrow.nerf");
    ok(&["export", s(&model), "--bits", "16", "--int8-layers", &all.join(","), "--out", s(&narrow)]);
    assert_eq!(psnr_of(&narrow), psnr_of(&d.join("m8a16.nerf")));
    assert_ne!(psnr_of(&narrow), psnr_of(&d.join("m16a16.nerf")));
    let e = fails(&["export", s(&model), "--bits", "8", "--int8-layers", "0", "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains("--int8-layers needs --bits 16"), "{e}");
    let e =
        fails(&["export", s(&model), "--bits", "16", "--int8-layers", &n.to_string(), "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains(&format!("layers 0 to {}", n - 1)), "{e}");
    assert!(!d.join("x.nerf").exists());
    // a narrow table needs a feature grid and an integer model
    let e = fails(&["export", s(&model), "--bits", "8", "--table-bits", "4", "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains(s(&model)) && e.contains("--table-bits 4") && e.contains("no feature grid"), "{e}");
    let e = fails(&["export", s(&model), "--bits", "32", "--table-bits", "8", "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains("--table-bits 8 needs --bits 16 or 8"), "{e}");
    assert!(!d.join("x.nerf").exists());
    // --coarse sets the default samples per ray, and rendering follows it
    let few = d.join("few.nerf");
    ok(&["export", s(&model), "--bits", "8", "--coarse", "4", "--out", s(&few)]);
    assert!(ok(&["info", s(&few)]).contains("samples: 4 coarse"));
    let r: serde_json::Value =
        serde_json::from_str(&ok(&["eval", s(&few), "--data", s(&data), "--split", "test"])).unwrap();
    // 4 coarse + (4 + 8) fine per ray that meets the scene bounds
    let few_spr = r["samples_per_ray"].as_f64().unwrap();
    assert!(few_spr > 4.0 && few_spr <= 16.0 && few_spr < spr, "{few_spr}");
    // --fine sets the default importance samples, and rendering follows it: 4 coarse + (4 + 2) fine at most
    let fewer = d.join("fewer.nerf");
    ok(&["export", s(&model), "--bits", "8", "--coarse", "4", "--fine", "2", "--out", s(&fewer)]);
    assert!(ok(&["info", s(&fewer)]).contains("samples: 4 coarse + 2 fine"));
    let r: serde_json::Value =
        serde_json::from_str(&ok(&["eval", s(&fewer), "--data", s(&data), "--split", "test"])).unwrap();
    let fewer_spr = r["samples_per_ray"].as_f64().unwrap();
    assert!(fewer_spr > 0.0 && fewer_spr <= 10.0 && fewer_spr < few_spr, "{fewer_spr}");
    let o = support::cli::nerf(&["export", s(&model), "--bits", "8", "--fine", "0", "--out", s(&d.join("x.nerf"))]);
    let e = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success() && e.contains("'0' for '--fine") && e.contains("1..=256"), "{e}");
    let o = support::cli::nerf(&["export", s(&model), "--bits", "8", "--coarse", "1", "--out", s(&d.join("x.nerf"))]);
    let e = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success() && e.contains("'1' for '--coarse") && e.contains("2..=1024"), "{e}");
    // this model has a fine network: at most 256 coarse samples
    let o =
        support::cli::nerf(&["export", s(&model), "--bits", "16", "--coarse", "257", "--out", s(&d.join("x.nerf"))]);
    let e = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success() && e.contains("x.nerf") && e.contains("sample counts"), "{e}");
    assert!(!d.join("x.nerf").exists());

    let t = d.join("trade");
    let table = ok(&[
        "tradeoff",
        s(&model),
        "--data",
        s(&data),
        "--split",
        "test",
        "--views",
        "1",
        "--repeats",
        "1",
        "--out",
        s(&t),
    ]);
    let csv = std::fs::read_to_string(t.join("tradeoff.csv")).unwrap();
    assert!(csv.starts_with("label,bits,coarse,fine,early_stop,psnr,ssim,us_per_ray,samples_per_ray,pareto,act_bits\n"));
    for label in ["f32 ", "int16 ", "int8 ", "int8/a8 "] {
        assert!(csv.lines().any(|l| l.starts_with(label)), "{label} missing:\n{csv}");
        assert!(table.contains(label), "{table}");
    }
    assert!(t.join("tradeoff.png").is_file());

    let orbit = d.join("orbit");
    ok(&["render", s(&model), "--orbit", "3", "--size", "12", "--out", s(&orbit)]);
    for f in ["orbit_000.png", "orbit_002_depth.png", "orbit.gif"] {
        assert!(orbit.join(f).is_file(), "{f} missing");
    }
    ok(&["render", s(&model), "--data", s(&data), "--split", "val", "--out", s(&d.join("val"))]);
    assert!(d.join("val/r_1_depth.png").is_file());
}

#[test]
fn a_config_file_overrides_the_named_preset() {
    let d = tmp("preset-config");
    let data = blender_scene(&d, 8, 2);
    let cfg = d.join("over.json");
    std::fs::write(&cfg, r#"{"n_coarse": 24, "feature_levels": 2, "feature_log2_table": 8}"#).unwrap();
    let run = d.join("run");
    let common = ["--iters", "2", "--val-views", "0"];
    ok(&[&["train", "--data", s(&data), "--preset", "features", "--config", s(&cfg), "--out", s(&run)], &common[..]]
        .concat());
    let info = ok(&["info", s(&run.join("model.nerf")), "--json"]);
    let v: serde_json::Value = serde_json::from_str(&info).unwrap();
    // the file's fields, and the preset's for the rest
    assert_eq!(v["samples"]["coarse"], 24);
    assert_eq!(v["features"]["levels"], 2);
    assert_eq!(v["features"]["log2_table"], 8);
    assert_eq!(v["topology"]["depth"], 2, "the preset's 2x64 network");
    assert!(v["grid"].is_object(), "the preset's occupancy grid");
    // an unknown field names the file
    std::fs::write(&cfg, r#"{"n_coarses": 24}"#).unwrap();
    let e = fails(
        &[&["train", "--data", s(&data), "--preset", "grid", "--config", s(&cfg), "--out", s(&run)], &common[..]]
            .concat(),
    );
    assert!(e.contains("over.json") && e.contains("n_coarses"), "{e}");
}

#[test]
fn train_sizes_the_feature_grid_to_the_photos_unless_the_config_does() {
    let d = tmp("fit-grid");
    // 300-pixel photos of the built-in scene resolve 416 cells per axis of its bounds: a finest level
    // of 512, one doubling of the preset's 256 and of its 2^15 table entries
    let data = blender_scene(&d, 300, 2);
    let train = |cfg: &str, name: &str, more: &[&str]| {
        let file = d.join(format!("{name}.json"));
        std::fs::write(&file, cfg).unwrap();
        let run = d.join(name);
        let args =
            [&["train", "--data", s(&data), "--config", s(&file), "--val-views", "0", "--out", s(&run)], more].concat();
        let o = support::cli::nerf(&args);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        let v: serde_json::Value = serde_json::from_str(&ok(&["info", s(&run.join("model.nerf")), "--json"])).unwrap();
        let res = v["features"]["resolutions"].as_array().unwrap().last().unwrap().as_u64().unwrap();
        (res, v["features"]["log2_table"].as_u64().unwrap(), err)
    };
    let (res, table, err) = train(r#"{"feature_levels": 2}"#, "fitted", &["--iters", "1"]);
    assert_eq!((res, table), (512, 16));
    assert!(err.contains("feature grid sized to the photos: finest level 512 cells per axis (was 256)"), "{err}");
    // the same configuration resumes: the checkpoint's is the fitted one
    let (res, table, _) = train(r#"{"feature_levels": 2}"#, "fitted", &["--iters", "2", "--resume"]);
    assert_eq!((res, table), (512, 16));
    // a configuration that names the finest level or the table keeps its grid
    for (cfg, want) in [
        (r#"{"feature_levels": 2, "feature_max_res": 256}"#, (256, 15)),
        (r#"{"features": {"levels": 2, "log2_table": 12}}"#, (256, 12)),
    ] {
        let (res, table, err) = train(cfg, "chosen", &["--iters", "1", "--force"]);
        assert_eq!((res, table), want, "{cfg}");
        assert!(!err.contains("sized to the photos"), "{err}");
    }
}

#[test]
fn bad_inputs_give_one_line_errors() {
    let d = tmp("errs");
    std::fs::create_dir_all(&d).unwrap();
    let e = fails(&["info", s(&d.join("nope.nerf"))]);
    assert!(e.contains("nope.nerf") && e.contains("cannot read"), "{e}");
    // a version newer than this build reads
    let newer = nerf_infer::format::FORMAT_VERSION + 1;
    std::fs::write(d.join("junk.nerf"), [&b"NERF"[..], &newer.to_le_bytes(), b"junkjunkjunk"].concat()).unwrap();
    let e = fails(&["info", s(&d.join("junk.nerf"))]);
    assert!(e.contains("junk.nerf") && e.contains(&format!("version {newer}")), "{e}");
    let e = fails(&["train", "--data", s(&d.join("nodata")), "--iters", "1", "--out", s(&d.join("r"))]);
    assert!(e.contains("nodata"), "{e}");
    let e = fails(&["train", "--data", s(&d), "--iters", "1", "--out", s(&d.join("r")), "--preset", "huge"]);
    // refused when the command line is parsed, naming the flag and the presets there are
    assert!(e.contains("'huge' for '--preset") && e.contains("possible values: features, grid, fast, paper"), "{e}");
}

#[test]
fn info_into_a_closed_pipe_ends_without_a_panic() {
    // `nerf info M | head -1`: the reader gone before the first line
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/scene_int8.nerf");
    let o = std::process::Command::new(support::cli::BIN).args(["info", model]).stdout(writer).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked") && err.is_empty(), "{err}");
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(o.status.signal(), Some(13), "{:?}", o.status); // SIGPIPE
}

#[test]
fn export_stores_the_feature_table_as_8_or_4_bit_codebook_indices() {
    let d = tmp("table-bits");
    let data = blender_scene(&d, 16, 6);
    let cfg = d.join("tiny.json");
    std::fs::write(
        &cfg,
        r#"{"width": 16, "view_width": 8, "feature_log2_table": 10, "feature_max_res": 32, "batch_rays": 64}"#,
    )
    .unwrap();
    let run = d.join("run");
    ok(&["train", "--data", s(&data), "--config", s(&cfg), "--iters", "20", "--out", s(&run), "--val-views", "0"]);
    let model = run.join("model.nerf");
    let info =
        |m: &std::path::Path| -> serde_json::Value { serde_json::from_str(&ok(&["info", s(m), "--json"])).unwrap() };
    let eval = |m: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&ok(&["eval", s(m), "--data", s(&data), "--split", "test"])).unwrap()
    };
    let f32_psnr = eval(&model)["psnr"].as_f64().unwrap();
    let mut table_bytes = Vec::new();
    for bits in ["16", "8", "4"] {
        let out = d.join(format!("t{bits}.nerf"));
        ok(&["export", s(&model), "--bits", "8", "--table-bits", bits, "--out", s(&out)]);
        let i = info(&out);
        assert_eq!(i["features"]["value_bits"].to_string(), bits, "{i}");
        // int8 exports carry the 16-bit density head (version 8), with any table, and keep the
        // orbit fitted to the training cameras (version 9)
        assert_eq!(i["precise"]["density_head"], true, "{i}");
        assert!(i["orbit"]["radius"].as_f64().is_some_and(|r| r > 0.0), "{i}");
        // (a scene on black: no proposal grid, the version before it)
        assert_eq!(i["format_version"], nerf_infer::format::FORMAT_VERSION_NO_PROPOSAL, "{i}");
        table_bytes.push(i["features"]["bytes"].as_u64().unwrap());
        let text = ok(&["info", s(&out)]);
        assert_eq!(text.contains(&format!("{bits}-bit indices into a codebook")), bits != "16", "{text}");
        let r = eval(&out);
        // the codebook's model renders the f32 model's pictures: a wrong image moves its PSNR by more
        let q = r["psnr"].as_f64().unwrap();
        assert!((q - f32_psnr).abs() < 0.05, "--table-bits {bits}: {q} dB, the f32 model {f32_psnr} dB");
    }
    // 2 bytes per value, then 1, then a half, padded to whole 4-byte words
    let values = table_bytes[0] / 2;
    assert_eq!([table_bytes[1], table_bytes[2]], [values.div_ceil(4) * 4, values.div_ceil(8) * 4]);
    // a model whose table is already narrow is not narrowed again
    let e =
        fails(&["export", s(&d.join("t4.nerf")), "--bits", "8", "--table-bits", "4", "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains("already quantised") || e.contains("already narrow"), "{e}");
    // one network and no proposal grid: no samples after the coarse pass to set
    let e = fails(&["export", s(&model), "--bits", "8", "--fine", "8", "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains(s(&model)) && e.contains("--fine 8") && e.contains("neither a fine network"), "{e}");
    assert!(!d.join("x.nerf").exists());
}

#[test]
fn proposal_grid_captures_get_the_distortion_loss_unless_the_config_names_it() {
    let d = tmp("fit-distortion");
    ok(&["scene", "--out", s(&d.join("scene")), "--size", "16"]);
    let train = |data: &str, cfg: &str, name: &str, more: &[&str]| {
        let file = d.join(format!("{name}.json"));
        std::fs::write(&file, cfg).unwrap();
        let run = d.join(name);
        let data = d.join("scene").join(data);
        let args = [
            &["train", "--data", s(&data), "--config", s(&file), "--iters", "1", "--val-views", "0", "--out", s(&run)],
            more,
        ]
        .concat();
        let o = support::cli::nerf(&args);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        let t = nerf_train::train::Trainer::from_bytes(&std::fs::read(run.join("checkpoint.bin")).unwrap()).unwrap();
        let bytes = std::fs::read(run.join("model.nerf")).unwrap();
        let (m, c) = (nerf_infer::format::Model::from_bytes(&bytes).unwrap().samples, t.cfg.samples());
        assert_eq!((m.coarse, m.fine), (c.coarse, c.fine), "the model records its configuration's samples");
        (t.cfg.sampling.proposal_res, t.cfg.loss.distortion, err)
    };
    // the room (unbounded): the proposal grid and the distortion loss, said on the terminal
    let (res, distortion, err) = train("room", "{}", "room", &[]);
    assert_eq!((res, distortion), (Some(TrainConfig::PROPOSAL_RES), TrainConfig::PROPOSAL_DISTORTION));
    assert!(err.contains("the distortion loss at 0.001"), "{err}");
    // trained at 32 network samples, rendered at 16 by default, said on the terminal
    let render = |run: &str| {
        let m = std::fs::read(d.join(run).join("model.nerf")).unwrap();
        nerf_infer::format::Model::from_bytes(&m).map(|m| m.samples.fine).unwrap()
    };
    assert_eq!(render("room"), TrainConfig::PROPOSAL_RENDER_MAIN.get());
    assert!(err.contains("the model renders at 16 unless told otherwise"), "{err}");
    let (res, _, _) = train("room", r#"{"sampling": {"n_main_render": 24}}"#, "room-render", &[]);
    assert_eq!((res, render("room-render")), (Some(TrainConfig::PROPOSAL_RES), 24));
    let (res, _, _) = train("room", r#"{"sampling": {"n_main_render": 0}}"#, "room-render-all", &[]);
    assert_eq!((res, render("room-render-all")), (Some(TrainConfig::PROPOSAL_RES), 32));
    // a chosen training count renders at itself
    let (res, _, _) = train("room", r#"{"sampling": {"n_main": 8}}"#, "room-main", &[]);
    assert_eq!((res, render("room-main")), (Some(TrainConfig::PROPOSAL_RES), 8));
    // out of range: refused by name, not trained without the grid
    let bad = d.join("bad.json");
    std::fs::write(&bad, r#"{"sampling": {"n_main_render": 300}}"#).unwrap();
    let data = d.join("scene").join("room");
    let e = fails(&["train", "--data", s(&data), "--config", s(&bad), "--iters", "1", "--out", s(&d.join("bad"))]);
    assert!(e.contains("sampling.n_main_render must be 0..=255"), "{e}");
    // a proposal grid's model takes at most 255 network samples
    let m = d.join("room").join("model.nerf");
    let e = fails(&["export", s(&m), "--bits", "8", "--fine", "256", "--out", s(&d.join("x.nerf"))]);
    assert!(e.contains(s(&m)) && e.contains("--fine 256") && e.contains("1..=255"), "{e}");
    assert!(!d.join("x.nerf").exists());
    // a configuration that names the weight keeps it
    let (res, distortion, err) = train("room", r#"{"distortion": 0}"#, "room-chosen", &[]);
    assert_eq!((res, distortion), (Some(TrainConfig::PROPOSAL_RES), 0.0));
    assert!(!err.contains("distortion loss"), "{err}");
    // a forward-facing capture: both too
    let (res, distortion, err) = train("llff", "{}", "forward", &[]);
    assert_eq!((res, distortion), (Some(TrainConfig::PROPOSAL_RES), TrainConfig::PROPOSAL_DISTORTION));
    assert!(err.contains("forward-facing") && err.contains("the distortion loss at 0.001"), "{err}");
    // and rendered at the network samples it trains with
    assert_eq!(render("forward"), 32);
    assert!(err.contains("the model renders at 32 unless told otherwise"), "{err}");
    // the same photos as an object scene: neither
    let (res, distortion, _) = train("colmap", "{}", "object", &["--scene", "object"]);
    assert_eq!((res, distortion), (None, 0.0));
}
