//! Ctrl-C and SIGTERM, one handler for every command ([`install`]). By
//! default an interrupt removes the temporary files being written (an
//! output cut short leaves nothing) and exits with status 130. A command
//! that stops cleanly ([`catch`]: a training step, a frame, a COLMAP
//! stage) counts the first interrupt instead and stops between units of
//! its work, leaving what its own rerun accepts; a second one exits as by
//! default. A command that runs its work in a child ([`forward_to`])
//! passes each interrupt on to it and never exits on one.

use std::sync::atomic::{AtomicU32, AtomicU8, Ordering};

/// Interrupt signals received since [`install`].
static INTERRUPTS: AtomicU32 = AtomicU32::new(0);
/// What an interrupt does: [`EXIT`], [`STOP`] or [`FORWARD`].
static MODE: AtomicU8 = AtomicU8::new(EXIT);
/// The child an interrupt is passed to in [`FORWARD`] mode (0: none).
static CHILD: AtomicU32 = AtomicU32::new(0);
const EXIT: u8 = 0;
const STOP: u8 = 1;
const FORWARD: u8 = 2;

/// Installs the handler (at the start of the program).
pub fn install() {
    let _ = ctrlc::set_handler(|| {
        let first = INTERRUPTS.fetch_add(1, Ordering::SeqCst) == 0;
        match MODE.load(Ordering::SeqCst) {
            FORWARD => {
                let child = CHILD.load(Ordering::SeqCst);
                #[cfg(unix)]
                if child != 0 {
                    // SAFETY: a signal to the child this process started and waits for; no memory is shared.
                    unsafe {
                        libc::kill(child as libc::pid_t, libc::SIGTERM);
                    }
                }
            }
            STOP if first => {}
            _ => {
                nerf_train::atomic::remove_in_flight();
                std::process::exit(130);
            }
        }
    });
}

/// The first interrupt from here on is counted ([`received`]) for the
/// command to stop between units of its work; a second one exits.
pub fn catch() {
    MODE.store(STOP, Ordering::SeqCst);
}

/// Each interrupt from here on is counted and passed on to the process
/// `child` (0: none yet), which stops cleanly; this process does not exit.
pub fn forward_to(child: u32) {
    CHILD.store(child, Ordering::SeqCst);
    MODE.store(FORWARD, Ordering::SeqCst);
}

/// Whether an interrupt has reached this process: a command that goes on
/// after training (`nerf bench`) stops too.
pub fn received() -> bool {
    INTERRUPTS.load(Ordering::SeqCst) > 0
}
