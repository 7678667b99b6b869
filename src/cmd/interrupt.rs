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
const STOP_EVERY: u8 = 3;

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
            STOP_EVERY => {}
            _ => {
                nerf_train::util::atomic::remove_in_flight();
                std::process::exit(130);
            }
        }
    });
}

/// The first interrupt from here on is counted ([`received`]) for the
/// command to stop between units of its work; a second one exits. For the
/// rest of the process (a training run, and what `nerf bench` does after it).
pub fn catch() {
    MODE.store(STOP, Ordering::SeqCst);
}

/// [`catch`] while the returned guard lives; then interrupts exit again
/// (`nerf demo` goes on to commands that do not stop on their own).
pub fn catch_while() -> Stopping {
    catch();
    Stopping
}

/// Returned by [`catch_while`]: restores the default when dropped.
pub struct Stopping;

impl Drop for Stopping {
    fn drop(&mut self) {
        let _ = MODE.compare_exchange(STOP, EXIT, Ordering::SeqCst, Ordering::SeqCst);
    }
}

/// Every interrupt from here on is counted and none exits: for a command
/// whose work (a child it waits for) stops promptly on [`received`], and
/// that must clean up after it (`nerf capture`).
pub fn catch_every() {
    MODE.store(STOP_EVERY, Ordering::SeqCst);
}

/// Interrupts exit again (the default), as after a child's work is done.
pub fn reset() {
    MODE.store(EXIT, Ordering::SeqCst);
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
