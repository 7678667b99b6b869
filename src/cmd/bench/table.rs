//! The bench's table, written from the rows the tasks left: `table.md`,
//! `table.csv`, `table.json`, and `psnr_minutes.png` (validation PSNR
//! against training minutes, a panel per scene, the published figure as a
//! dashed line).

use super::task::{read_row, Row};
use super::Settings;
use crate::cmd::{write_atomic, CmdError, CmdResult};
use std::fmt::Write as _;
use std::path::Path;

/// When, with what build and on what CPU a row was made.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stamp {
    /// UTC date, `YYYY-MM-DD`.
    pub date: String,
    /// The commit the `nerf` binary was built from (`unknown` outside a git checkout).
    pub commit: String,
    /// The CPU's model name (`/proc/cpuinfo`), and the cores available to the task.
    pub cpu: String,
}

impl Stamp {
    /// This process's stamp, now.
    pub fn now() -> Self {
        let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
        let (y, m, d) = civil_date((secs / 86_400) as i64);
        let model = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|t| {
                t.lines()
                    .find(|l| l.starts_with("model name"))
                    .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_owned())
            })
            .unwrap_or_else(|| std::env::consts::ARCH.to_owned());
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        Self {
            date: format!("{y:04}-{m:02}-{d:02}"),
            commit: env!("NERF_COMMIT").to_owned(),
            cpu: format!("{model}, {cores} cores"),
        }
    }
}

/// The proleptic Gregorian date of `days` since 1970-01-01 (Howard
/// Hinnant's `civil_from_days`).
fn civil_date(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// Writes the table from the rows in `out`; names the scenes with no row
/// (a task that has not run or did not finish) and the failed ones.
pub fn gather(settings: &Settings, out: &Path) -> CmdResult {
    let mut rows = Vec::new();
    let (mut missing, mut failed) = (Vec::new(), Vec::new());
    for (i, s) in settings.scenes.iter().enumerate() {
        match read_row(out, s) {
            Some(Ok(r)) => {
                if let Some(e) = &r.error {
                    failed.push(format!("task {i} ({}): {e}", s.name));
                }
                rows.push(r);
            }
            Some(Err(e)) => {
                failed.push(format!("task {i} ({}): {e}", s.name));
                rows.push(Row { error: Some(e.to_string()), ..Row::of(s, i) });
            }
            None => missing.push(format!("task {i} ({})", s.name)),
        }
    }
    if rows.is_empty() {
        return Err(CmdError::File {
            path: out.to_path_buf(),
            reason: format!(
                "no task has left a result yet ({} scenes; none of {}/NAME/result.json exists)",
                settings.scenes.len(),
                out.join("scenes").display()
            ),
        });
    }
    write_atomic(&out.join("table.md"), markdown(settings, &rows, &missing).as_bytes())?;
    write_atomic(&out.join("table.csv"), csv(&rows).as_bytes())?;
    let json = serde_json::to_string_pretty(&rows)?;
    write_atomic(&out.join("table.json"), json.as_bytes())?;
    let panels: Vec<nerf_train::plot::Panel> = rows
        .iter()
        .map(|r| nerf_train::plot::Panel {
            title: r.scene.clone(),
            curve: r.curve.clone(),
            reference: r.published.map(|p| p.0),
        })
        .collect();
    nerf_train::plot::panels(&out.join("psnr_minutes.png"), "PSNR (dB) against training minutes", &panels)?;
    for m in &missing {
        eprintln!("warning: {m}: no result yet (not run, or stopped before it finished)");
    }
    for f in &failed {
        eprintln!("warning: {f}");
    }
    let n = settings.scenes.len();
    eprintln!("wrote {} ({} rows of {n} scenes)", out.join("table.md").display(), rows.len());
    if failed.is_empty() && missing.is_empty() {
        return Ok(());
    }
    Err(CmdError::Unreached(format!(
        "{} of {n} scenes failed, {} have no result yet (named above); {} holds the rest",
        failed.len(),
        missing.len(),
        out.join("table.md").display()
    )))
}

/// `x` with `d` decimals, or blank.
fn opt(x: Option<f64>, d: usize) -> String {
    x.map(|v| format!("{v:.d$}")).unwrap_or_default()
}

/// The Markdown table, headed by what it was measured with.
fn markdown(settings: &Settings, rows: &[Row], missing: &[String]) -> String {
    let mut s = String::new();
    let budget = match (settings.minutes, settings.iters) {
        (Some(m), _) => format!("{m} minutes"),
        (_, Some(n)) => format!("{n} steps"),
        _ => String::new(),
    };
    let _ = writeln!(s, "# nerf bench: {}\n", settings.suite.display());
    let _ = writeln!(
        s,
        "Training budget {budget} per scene, seed {}, preset {}{}. PSNR (dB) and SSIM over every scored view, \
         rendered as the model renders (no early termination); µs per ray on one core with early termination \
         at 1e-3, median of the first two views; NeRF: the 2020 paper's figure at this protocol.\n",
        settings.seed,
        settings.preset.as_deref().unwrap_or("default"),
        settings.config.as_ref().map(|(p, _)| format!(", --config {}", p.display())).unwrap_or_default()
    );
    let mut stamps: Vec<&Stamp> = rows.iter().map(|r| &r.stamp).filter(|s| !s.date.is_empty()).collect();
    stamps.sort_by(|a, b| (&a.date, &a.commit, &a.cpu).cmp(&(&b.date, &b.commit, &b.cpu)));
    stamps.dedup();
    for st in stamps {
        let _ = writeln!(s, "- {}, commit {}, {}", st.date, st.commit, st.cpu);
    }
    s.push_str(
        "\n| # | scene | protocol | steps | min | PSNR f32 | SSIM f32 | PSNR int8 | SSIM int8 | µs/ray f32 | µs/ray int8 | \
         peak MiB | NeRF PSNR | NeRF SSIM |\n|--:|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n",
    );
    for r in rows {
        let (f, q) = (r.f32.as_ref(), r.int8.as_ref());
        let size = r.size.map(|(w, h)| format!(", {w}×{h}")).unwrap_or_default();
        let _ = writeln!(
            s,
            "| {} | {} | {}{size}, {} ({} views) | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.index,
            r.scene,
            r.kind,
            r.split,
            r.views,
            r.steps.map(|n| n.to_string()).unwrap_or_default(),
            opt(r.minutes, 2),
            opt(f.map(|x| x.psnr), 2),
            opt(f.map(|x| x.ssim), 3),
            opt(q.map(|x| x.psnr), 2),
            opt(q.map(|x| x.ssim), 3),
            opt(f.map(|x| x.us_per_ray), 2),
            opt(q.map(|x| x.us_per_ray), 2),
            opt(r.peak_mib, 0),
            opt(r.published.map(|p| p.0), 2),
            opt(r.published.map(|p| p.1), 3),
        );
    }
    let failed: Vec<&Row> = rows.iter().filter(|r| r.error.is_some()).collect();
    if !failed.is_empty() || !missing.is_empty() {
        s.push('\n');
    }
    for r in failed {
        let _ = writeln!(s, "- {} failed: {}", r.scene, r.error.as_deref().unwrap_or_default());
    }
    for m in missing {
        let _ = writeln!(s, "- {m}: no result (not run, or stopped before it finished)");
    }
    s.push_str("\n![PSNR against training minutes](psnr_minutes.png)\n");
    s
}

/// `v` as a CSV field (quoted where it holds a comma, quote or line break).
fn field(v: &str) -> String {
    if v.contains([',', '"', '\n']) {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_owned()
    }
}

/// The CSV table: a header, then a row per scene.
fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "index,scene,kind,downscale,split,width,height,views,steps,minutes,psnr_f32,ssim_f32,us_per_ray_f32,\
         psnr_int8,ssim_int8,us_per_ray_int8,bytes_f32,bytes_int8,peak_mib,nerf_psnr,nerf_ssim,date,commit,cpu,threads,error\n",
    );
    for r in rows {
        let (f, q) = (r.f32.as_ref(), r.int8.as_ref());
        let cells = [
            r.index.to_string(),
            r.scene.clone(),
            r.kind.clone(),
            r.downscale.to_string(),
            r.split.clone(),
            r.size.map(|s| s.0.to_string()).unwrap_or_default(),
            r.size.map(|s| s.1.to_string()).unwrap_or_default(),
            r.views.to_string(),
            r.steps.map(|n| n.to_string()).unwrap_or_default(),
            opt(r.minutes, 3),
            opt(f.map(|x| x.psnr), 3),
            opt(f.map(|x| x.ssim), 4),
            opt(f.map(|x| x.us_per_ray), 3),
            opt(q.map(|x| x.psnr), 3),
            opt(q.map(|x| x.ssim), 4),
            opt(q.map(|x| x.us_per_ray), 3),
            f.map(|x| x.bytes.to_string()).unwrap_or_default(),
            q.map(|x| x.bytes.to_string()).unwrap_or_default(),
            opt(r.peak_mib, 1),
            opt(r.published.map(|p| p.0), 2),
            opt(r.published.map(|p| p.1), 3),
            r.stamp.date.clone(),
            r.stamp.commit.clone(),
            r.stamp.cpu.clone(),
            r.threads.to_string(),
            r.error.clone().unwrap_or_default(),
        ];
        let line: Vec<String> = cells.iter().map(|c| field(c)).collect();
        s.push_str(&line.join(","));
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_of_known_days() {
        assert_eq!(civil_date(0), (1970, 1, 1));
        assert_eq!(civil_date(11_016), (2000, 2, 29));
        assert_eq!(civil_date(20_793), (2026, 12, 6));
    }

    #[test]
    fn csv_fields_with_commas_and_quotes_are_quoted() {
        assert_eq!(field("a"), "a");
        assert_eq!(field("AMD EPYC, 2 cores"), "\"AMD EPYC, 2 cores\"");
        assert_eq!(field("say \"x\""), "\"say \"\"x\"\"\"");
    }
}
