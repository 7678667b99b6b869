//! Ctrl-C and SIGTERM for the commands that stop cleanly: the first is
//! counted, and the command stops between units of its work (a training
//! step, a frame, a COLMAP stage), leaving what its own rerun accepts; a
//! second one exits at once (outputs are written atomically).

use std::sync::atomic::{AtomicU32, Ordering};

/// Interrupt signals received since [`catch`] installed the handler.
static INTERRUPTS: AtomicU32 = AtomicU32::new(0);

/// Installs the handler (once per process; later calls do nothing).
pub fn catch() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            if INTERRUPTS.fetch_add(1, Ordering::SeqCst) > 0 {
                std::process::exit(130);
            }
        });
    });
}

/// Whether an interrupt has reached this process since [`catch`]: a
/// command that goes on after training (`nerf bench`) stops too.
pub fn received() -> bool {
    INTERRUPTS.load(Ordering::SeqCst) > 0
}
