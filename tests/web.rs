//! `nerf web`: the page's files, the module's pixels against the host's
//! (natively, through the same C ABI the page calls), and, with Chromium,
//! the page itself in a headless browser against `nerf render`'s PNG.

mod support;

use nerf_infer::format::crc32;
use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::num::NonZeroU8;
use std::path::{Path, PathBuf};
use support::cli::{fails, ok, s, tmp};

/// The models the page is checked on: the workspace's int8 and f32 models
/// of the built-in scene (4×64 networks, coarse and fine), and an int8
/// model with a feature grid and odd layer widths (45 inputs, a 16-wide
/// view layer, 3 colours), random weights, written into `dir`.
fn models(dir: &Path) -> Vec<PathBuf> {
    use nerf_train::export::{quantise, random_model};
    let cfg = support::small_config().with(|c| {
        c.sampling.n_fine = None;
        c.features.levels = NonZeroU8::new(3);
        c.features.log2_table = 9;
        c.features.min_res = 2;
        c.features.max_res = 40;
    });
    let f32_bytes = random_model(&cfg, support::unit_scene(), 7, 4.0).unwrap().to_bytes().unwrap();
    let m = nerf_infer::Model::from_bytes(&f32_bytes).unwrap();
    let int8 = quantise(&m, nerf_infer::Scheme::I8).unwrap().to_bytes().unwrap();
    let features = dir.join("features_int8.nerf");
    std::fs::write(&features, int8).unwrap();
    let shipped = |name: &str| Path::new(env!("CARGO_MANIFEST_DIR")).join("models").join(name);
    vec![shipped("scene_int8.nerf"), shipped("scene.nerf"), features]
}

/// The RGB bytes (row-major from the top row) of the one PNG `nerf render
/// MODEL --orbit 1 --size 64` writes, and their CRC-32.
fn host_frame(model: &Path, dir: &Path) -> (Vec<u8>, u32) {
    let out = dir.join("host");
    ok(&["render", s(model), "--orbit", "1", "--size", "64", "--out", s(&out)]);
    let png = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            let name = p.file_name().unwrap().to_str().unwrap();
            name.ends_with("_000.png") && !name.contains("depth") && !name.contains("opacity")
        })
        .expect("the orbit's frame");
    let rgb = image::open(&png).unwrap().to_rgb8().into_raw();
    let crc = crc32(&rgb);
    (rgb, crc)
}

/// Renders the page's check camera through the module's exported functions.
fn module_frame(model: &Path, view: &serde_json::Value) -> Vec<u8> {
    let bytes = std::fs::read(model).unwrap();
    let c = &view["check"];
    let (w, h) = (c["width"].as_u64().unwrap() as u32, c["height"].as_u64().unwrap() as u32);
    let values: Vec<f32> =
        c["camera_bits"].as_array().unwrap().iter().map(|b| f32::from_bits(b.as_u64().unwrap() as u32)).collect();
    let p = nerf_web::nerf_alloc(bytes.len());
    // SAFETY: p is a buffer of bytes.len() bytes from nerf_alloc, written once and loaded once
    unsafe {
        std::ptr::copy_nonoverlapping(bytes.as_ptr(), p, bytes.len());
        assert_ne!(nerf_web::nerf_load(p, bytes.len()), 0);
        std::ptr::copy_nonoverlapping(values.as_ptr(), nerf_web::nerf_camera_ptr(), 16);
    }
    assert_eq!(nerf_web::nerf_set_camera(w, h), 1);
    let mut rgb = Vec::new();
    // in 16×16 tiles as the page draws them (a partial last row and column at other sizes)
    for ty in (0..h).step_by(16) {
        let th = 16.min(h - ty);
        let mut rows = vec![Vec::new(); th as usize];
        for tx in (0..w).step_by(16) {
            let tw = 16.min(w - tx);
            let px = nerf_web::nerf_render(tx, ty, tw, th);
            assert!(!px.is_null());
            // SAFETY: nerf_render returns tw·th·4 bytes valid until the next call
            let rgba = unsafe { std::slice::from_raw_parts(px, (tw * th * 4) as usize) };
            for (k, p) in rgba.chunks_exact(4).enumerate() {
                rows[k / tw as usize].extend_from_slice(&p[..3]);
            }
        }
        rgb.extend(rows.concat());
    }
    rgb
}

#[test]
fn the_module_renders_the_hosts_pixels_and_the_folder_holds_the_page() {
    let models_dir = tmp("web-models");
    for m in models(&models_dir) {
        let name = m.file_name().unwrap().to_str().unwrap();
        let dir = tmp(&format!("web-{name}"));
        let out = dir.join("page");
        ok(&["web", s(&m), "--out", s(&out)]);
        for f in ["index.html", "nerf_web.wasm", "model.nerf", "view.json"] {
            assert!(out.join(f).is_file(), "{name}: {f}");
        }
        assert_eq!(std::fs::read(out.join("model.nerf")).unwrap(), std::fs::read(&m).unwrap());
        assert_eq!(&std::fs::read(out.join("nerf_web.wasm")).unwrap()[..4], b"\0asm");
        let view: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("view.json")).unwrap()).unwrap();
        let (host, _) = host_frame(&m, &dir);
        assert_eq!(module_frame(&m, &view), host, "{name}: the module's frame is the host's PNG");
        // an earlier page is replaced; a folder that holds a user's file is refused, and left as it was
        ok(&["web", s(&m), "--out", s(&out)]);
        std::fs::write(out.join("notes.txt"), b"mine").unwrap();
        let e = fails(&["web", s(&m), "--out", s(&out)]);
        assert!(e.contains("--out") && e.contains("notes.txt") && e.contains("did not write"), "{e}");
        assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");
    }
}

/// Serves `dir` over HTTP on 127.0.0.1 (GET only, one request per
/// connection) from a background thread; returns the port.
fn serve(dir: PathBuf) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut stream) = stream else { continue };
            let mut line = String::new();
            if BufReader::new(&stream).read_line(&mut line).is_err() {
                continue;
            }
            let path = line.split_whitespace().nth(1).unwrap_or("/").split('?').next().unwrap_or("/").to_string();
            let name = path.trim_start_matches('/');
            let file = dir.join(if name.is_empty() { "index.html" } else { name });
            let (status, body) = match std::fs::read(&file) {
                Ok(b) if !name.contains("..") => ("200 OK", b),
                _ => ("404 Not Found", Vec::new()),
            };
            let kind = match file.extension().and_then(|e| e.to_str()) {
                Some("html") => "text/html; charset=utf-8",
                Some("wasm") => "application/wasm",
                Some("json") => "application/json",
                _ => "application/octet-stream",
            };
            let head = format!(
                "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                body.len()
            );
            let _ = stream.write_all(head.as_bytes()).and_then(|_| stream.write_all(&body));
        }
    });
    port
}

/// Opens `url` in headless Chromium and returns the JSON the page logs
/// after `nerf-check ` (the page's console goes to Chromium's stderr);
/// fails after two minutes.
fn chromium_check(url: &str, profile: &Path) -> serde_json::Value {
    use std::process::{Command, Stdio};
    let mut child = Command::new("chromium")
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0"])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(url)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run chromium");
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut log = String::new();
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if let Some(i) = line.find("nerf-check ") {
                // the console line quotes the message: "nerf-check {...}", source: ...
                let rest = &line[i + "nerf-check ".len()..];
                let _ = tx.send(Ok(rest[..rest.rfind("\", source:").unwrap_or(rest.len())].to_string()));
                return;
            }
            log.push_str(&line);
            log.push('\n');
        }
        let _ = tx.send(Err(log));
    });
    let got = rx.recv_timeout(std::time::Duration::from_secs(120));
    let _ = child.kill();
    let _ = child.wait();
    match got {
        Ok(Ok(json)) => serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}: {json}")),
        Ok(Err(log)) => panic!("Chromium ended without the page's result:\n{log}"),
        Err(_) => panic!("no result from the page within two minutes"),
    }
}

/// With `NERF_WEB_MODEL=FILE`, that model is checked (and timed) after
/// the others: `NERF_WEB_MODEL=lego_int8.nerf cargo test --release --test
/// web -- --ignored --nocapture` gives its browser/native ratio.
#[test]
#[ignore = "needs Chromium (Debian's chromium package); .ci/run installs it and runs this test"]
fn the_page_in_headless_chromium_renders_the_hosts_frame() {
    let models_dir = tmp("web-chromium-models");
    let mut all = models(&models_dir);
    all.extend(std::env::var_os("NERF_WEB_MODEL").map(PathBuf::from));
    for m in all {
        let name = m.file_name().unwrap().to_str().unwrap();
        let dir = tmp(&format!("web-chromium-{name}"));
        let page = dir.join("page");
        ok(&["web", s(&m), "--out", s(&page)]);
        let (_, host_crc) = host_frame(&m, &dir);
        let view: serde_json::Value = serde_json::from_slice(&std::fs::read(page.join("view.json")).unwrap()).unwrap();
        // native: the same calls on this thread, the second of two renders timed as the page does
        module_frame(&m, &view);
        let t = std::time::Instant::now();
        module_frame(&m, &view);
        let native_us = t.elapsed().as_secs_f64() * 1e6 / (64.0 * 64.0);
        let port = serve(page);
        // the orbit's frames timed for the small model only (a 200x200 frame
        // of the built-in scene's networks takes seconds)
        let orbit = if name.starts_with("features") { "&orbit=2" } else { "" };
        let url = format!("http://127.0.0.1:{port}/index.html?check=1{orbit}");
        let result = chromium_check(&url, &dir.join("profile"));
        assert_eq!(result["crc32"].as_u64(), Some(host_crc as u64), "{name}: {result}");
        let us = result["us_per_ray"].as_f64().unwrap();
        assert!(us > 0.0, "{name}: {result}");
        // the viewer's frame, drawn over its workers
        let workers = result["workers"].as_u64().unwrap_or(0);
        let frame_ms = result["frame_ms_100"].as_f64().unwrap_or(-1.0);
        assert!(workers >= 1 && frame_ms >= 0.0, "{name}: {result}");
        let orbit_fps = result["orbit_fps_200"].as_f64();
        assert_eq!(orbit_fps.is_some_and(|f| f > 0.0), !orbit.is_empty(), "{name}: {result}");
        eprintln!(
            "{name}: CRC-32 {host_crc:08x} as the host's; µs per ray: browser {us:.2}, native {native_us:.2} \
             (one core), ratio {:.2}; a 100x100 frame in {frame_ms:.1} ms over {workers} workers ({:.1} ms on one \
             thread); 200x200 orbit frames per second: {orbit_fps:?}",
            us / native_us,
            result["frame_ms_100_one_thread"].as_f64().unwrap_or(-1.0)
        );
    }
}
