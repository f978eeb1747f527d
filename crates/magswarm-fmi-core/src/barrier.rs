//! The panic barrier every entry point of every shell runs its body in.
//!
//! No panic may unwind into the importer's C code (that aborts its process), and none may
//! be printed on its stderr: the shells run each call under [`barrier`] (`catch_unwind`
//! with a quiet panic hook in force) and turn a caught panic into an error status with the
//! panic's message in the importer's log ([`panic_message`]).

use std::panic::{catch_unwind, AssertUnwindSafe};

/// The message of a caught panic (its `&str` or `String` payload).
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Drop a panic payload without letting a panicking destructor escape.
pub fn drop_payload(payload: Box<dyn std::any::Any + Send>) {
    let _ = barrier(move || drop(payload));
}

/// Report a panic caught at an entry point: its message through `fail` (the instance's
/// logger, itself run under the barrier), the payload dropped safely. Returns what `fail`
/// returned, or Error where reporting panicked too. One body for every shell.
#[cold]
#[inline(never)]
pub fn report_panic(
    payload: Box<dyn std::any::Any + Send>,
    fail: impl FnOnce(String) -> crate::Status,
) -> crate::Status {
    let msg = panic_message(&*payload);
    drop_payload(payload);
    match barrier(|| fail(format!("internal error: the model panicked: {msg}"))) {
        Ok(s) => s,
        Err(p) => {
            drop_payload(p);
            crate::Status::Error
        }
    }
}

thread_local! {
    /// How deep this thread is inside the shell's panic barrier.
    static IN_BARRIER: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// The panic hook in force before the shell installed its own (called for panics outside
/// the barrier, so a Rust host linking the shell keeps its own reporting).
static PREVIOUS_HOOK: std::sync::OnceLock<PanicHook> = std::sync::OnceLock::new();
/// A panic hook as `std::panic::take_hook` returns it.
type PanicHook = Box<dyn Fn(&std::panic::PanicHookInfo<'_>) + Sync + Send>;
static HOOK: std::sync::Once = std::sync::Once::new();

/// Install (once) a panic hook that stays silent for panics inside the barrier: an FMU must
/// never write to its host's stderr; the message reaches the importer through the logger
/// instead. Panics elsewhere go to the previous hook. In the FMU's own shared library this
/// hook belongs to the library's private copy of std, so the host's hook is not touched.
#[inline]
fn quiet_panics() {
    // Every call after the first: one atomic load, inline in the entry point.
    if !HOOK.is_completed() {
        install_quiet_hook();
    }
}

/// The first call of [`quiet_panics`] (and calls while the thread is panicking): install
/// the hook, out of line.
#[cold]
#[inline(never)]
fn install_quiet_hook() {
    // `set_hook` panics when called while the thread is panicking (e.g. a Rust host freeing
    // instances while unwinding): try again at a later call.
    if std::thread::panicking() {
        return;
    }
    HOOK.call_once(|| {
        let _ = PREVIOUS_HOOK.set(std::panic::take_hook());
        std::panic::set_hook(Box::new(|info| {
            if IN_BARRIER.with(|d| d.get()) > 0 {
                return;
            }
            if let Some(prev) = PREVIOUS_HOOK.get() {
                prev(info);
            }
        }));
    });
}

/// `catch_unwind` with the quiet hook in force: the panic barrier of every entry point.
#[inline]
pub fn barrier<R>(f: impl FnOnce() -> R) -> std::thread::Result<R> {
    quiet_panics();
    // One thread-local lookup for both the increment and the decrement (in a shared library
    // each lookup is a call into the dynamic loader).
    IN_BARRIER.with(|d| {
        d.set(d.get() + 1);
        let r = catch_unwind(AssertUnwindSafe(f));
        d.set(d.get().saturating_sub(1));
        r
    })
}
