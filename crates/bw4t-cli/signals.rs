//! SIGINT (Ctrl-C) and SIGTERM for long runs: the first asks the run to stop cleanly (it
//! sets a flag the run watches), a second ends the process at once.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

/// Which signal arrived, once one has.
#[derive(Clone, Default)]
pub(crate) struct Received(Arc<AtomicU8>);

impl Received {
    /// The signal's number (2 for SIGINT, 15 for SIGTERM), if one arrived.
    pub(crate) fn number(&self) -> Option<u8> {
        Some(self.0.load(Ordering::SeqCst)).filter(|&n| n != 0)
    }
}

/// Starts watching for SIGINT and SIGTERM: the first sets `stop`, a second exits with
/// status 128 + its number. Returns once the handlers are in place, so a signal sent after
/// that is never lost.
#[cfg(unix)]
pub(crate) fn watch(stop: Arc<AtomicBool>) -> Received {
    use tokio::signal::unix::{SignalKind, signal};
    let received = Received::default();
    let seen = received.clone();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build();
        let Ok(runtime) = runtime else { return };
        runtime.block_on(async move {
            let (Ok(mut interrupt), Ok(mut terminate)) =
                (signal(SignalKind::interrupt()), signal(SignalKind::terminate()))
            else {
                return;
            };
            let _ = ready_tx.send(());
            loop {
                let number: u8 = tokio::select! {
                    _ = interrupt.recv() => 2,
                    _ = terminate.recv() => 15,
                };
                if stop.swap(true, Ordering::SeqCst) {
                    eprintln!("bw4t: stopped at once; the matches under way are lost");
                    std::process::exit(i32::from(crate::status::SIGNAL_BASE + number));
                }
                seen.0.store(number, Ordering::SeqCst);
                eprintln!("bw4t: stopping: finishing the matches under way (signal again to stop at once)");
            }
        });
    });
    // Without handlers (no runtime), signals keep their default effect; nothing to wait for.
    let _ = ready_rx.recv();
    received
}

/// Signals keep their default effect where they cannot be watched.
#[cfg(not(unix))]
pub fn watch(_stop: Arc<AtomicBool>) -> Received {
    Received::default()
}
