//! The programs `nerf capture` runs (COLMAP's stages, ffmpeg): found and
//! checked to be what they are named, run headless with their output in
//! the capture's log, shown while they run, stopped on an interrupt.

use crate::cmd::{interrupt, CmdError, CmdResult};
use std::io::{BufRead, BufReader, IsTerminal, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How often a stage says it is still running when no terminal shows its spinner.
const HEARTBEAT: Duration = Duration::from_secs(30);

/// `program` if it runs and answers as `package` does (COLMAP's `help`
/// or ffmpeg's `-version` names it), else an error naming `flag` and how
/// to install `package`.
pub fn find_program(program: &Path, flag: &'static str, package: &str) -> CmdResult<PathBuf> {
    let probe = if package == "ffmpeg" { "-version" } else { "help" };
    let out = Command::new(program).arg(probe).stdin(Stdio::null()).output().map_err(|e| CmdError::Flag {
        flag,
        reason: format!(
            "{}: cannot run it ({e}); install {package} (Debian/Ubuntu: apt-get install {package}; macOS: brew \
             install {package}) or give its path with {flag}",
            program.display()
        ),
    })?;
    let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    if !said.to_ascii_lowercase().contains(package) {
        return Err(CmdError::Flag {
            flag,
            reason: format!(
                "{}: `{} {probe}` does not answer as {package} does (its output does not name {package}); give the \
                 {package} program with {flag}",
                program.display(),
                program.display()
            ),
        });
    }
    Ok(program.to_path_buf())
}

/// Runs `program args` (in `dir`, if given) headless (no display: Qt's offscreen
/// platform), its output appended to `log`, with a spinner showing the
/// stage, its time and the program's last progress line (or, with no
/// terminal, a line every 30 s); an interrupt stops the program. An error
/// names the stage and the program's last lines.
pub fn run(
    program: &Path,
    args: &[std::ffi::OsString],
    dir: Option<&Path>,
    stage: &str,
    log: &mut std::fs::File,
) -> CmdResult {
    let _ = writeln!(
        log,
        "== {stage}: {} {}",
        program.display(),
        args.iter().map(|a| a.to_string_lossy()).collect::<Vec<_>>().join(" ")
    );
    // a relative program path names a file from this process's folder, not `dir`
    let program = match dir {
        Some(_) if program.components().count() > 1 => std::path::absolute(program).unwrap_or(program.into()),
        _ => program.to_path_buf(),
    };
    let mut cmd = Command::new(&program);
    if let Some(d) = dir {
        cmd.current_dir(d);
    }
    // its own process group: an interrupt stops the program and whatever it started
    #[cfg(unix)]
    std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
    let mut child = cmd
        .args(args)
        .env("QT_QPA_PLATFORM", "offscreen")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| CmdError::Program {
            stage: stage.into(),
            reason: format!("cannot run {}: {e}", program.display()),
        })?;
    let pb = indicatif::ProgressBar::new_spinner();
    pb.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {prefix} [{elapsed}] {wide_msg}").expect("template"),
    );
    pb.set_prefix(stage.to_string());
    pb.enable_steady_tick(Duration::from_millis(200));
    let heartbeat = !std::io::stderr().is_terminal();
    // both streams into one channel of lines: COLMAP logs to stderr, ffmpeg too
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let pipe = |r: Box<dyn Read + Send>, tx: std::sync::mpsc::Sender<String>| {
        std::thread::spawn(move || {
            for line in BufReader::new(r).split(b'\n').map_while(Result::ok) {
                // ffmpeg ends its progress lines with \r
                for part in String::from_utf8_lossy(&line).split('\r') {
                    let _ = tx.send(part.to_string());
                }
            }
        })
    };
    let a = pipe(Box::new(child.stdout.take().expect("piped")), tx.clone());
    let b = pipe(Box::new(child.stderr.take().expect("piped")), tx);
    let mut tail: std::collections::VecDeque<String> = Default::default();
    let (start, mut beat) = (Instant::now(), Instant::now());
    let mut stopped: Option<Instant> = None;
    loop {
        match rx.recv_timeout(Duration::from_millis(200)) {
            Ok(line) => {
                let _ = writeln!(log, "{line}");
                let t = line.trim();
                if t.contains('[') && t.contains('/') || t.starts_with("Registering image") || t.starts_with("frame=") {
                    pb.set_message(t.chars().take(80).collect::<String>());
                }
                if !t.is_empty() {
                    tail.push_back(t.to_string());
                    if tail.len() > 4 {
                        tail.pop_front();
                    }
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
        }
        if interrupt::received() && stopped.is_none() {
            #[cfg(unix)]
            // SAFETY: a signal to the process group this function started; no memory is shared.
            unsafe {
                libc::kill(-(child.id() as libc::pid_t), libc::SIGKILL);
            }
            let _ = child.kill();
            stopped = Some(Instant::now());
        }
        // a stopped program's pipes may stay open in what it left running: not waited for long
        if stopped.is_some_and(|t| t.elapsed() > Duration::from_secs(2)) {
            break;
        }
        if heartbeat && beat.elapsed() >= HEARTBEAT {
            beat = Instant::now();
            let last = tail.back().map(|l| format!("; its last line: {l}")).unwrap_or_default();
            eprintln!("{stage}: running for {:.0} s{last}", start.elapsed().as_secs_f64());
        }
    }
    if stopped.is_none() {
        let _ = (a.join(), b.join());
    }
    let status = child.wait().map_err(|e| CmdError::Program { stage: stage.into(), reason: e.to_string() })?;
    pb.finish_and_clear();
    if stopped.is_some() {
        return Err(CmdError::Interrupted(format!("{stage}: interrupted; {} stopped", program.display())));
    }
    if !status.success() {
        let last: Vec<String> = tail.into_iter().collect();
        return Err(CmdError::Program {
            stage: stage.into(),
            reason: format!("{} failed ({status}); its last lines: {}", program.display(), last.join(" | ")),
        });
    }
    eprintln!("{stage}: done in {:.1} s", start.elapsed().as_secs_f64());
    Ok(())
}

/// The cause COLMAP's log names for a reconstruction that failed or
/// registered no photo, in the user's terms.
pub fn diagnose(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    if text.contains("different dimensions") {
        "COLMAP skipped photos whose size differs from the first one's: give --camera-per-photo".into()
    } else if text.contains("No good initial image pair") || text.contains("No images with matches") {
        "COLMAP found no pair of photos to start from: photos need more overlap (each sharing about two thirds of its \
         view with its neighbours) and texture"
            .into()
    } else {
        "COLMAP found no model: photos need more overlap (each sharing about two thirds of its view with its \
         neighbours) and texture"
            .into()
    }
}
