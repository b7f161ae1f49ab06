//! Interrupts and limits, handled as errors: SIGINT, SIGTERM and SIGHUP end the command with
//! one line, after removing its temporary files and folders
//! (`render::output::remove_temporaries`), and a file-size limit (`ulimit -f`) makes the
//! write that passes it fail with an error (`EFBIG`) instead of killing the process with
//! SIGXFSZ, so the atomic write removes its temporary and the message names the output.

/// Install the handling: call it first in `main`, before any thread starts, so that every
/// thread (rayon's pool included) inherits the blocked signals and only the handler's
/// thread receives them.
pub fn install() {
    #[cfg(unix)]
    // SAFETY: plain libc calls on a sigset_t of our own, before any other thread exists;
    // SIG_IGN for SIGXFSZ is what POSIX defines for turning the signal into EFBIG.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for s in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            libc::sigaddset(&mut set, s);
        }
        if libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) != 0 {
            return;
        }
        let waited = Set(set);
        let spawned = std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || wait(waited));
        if spawned.is_err() {
            // No handler thread: take the default actions back.
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        }
    }
}

/// A signal set that may move to the handler's thread.
#[cfg(unix)]
struct Set(libc::sigset_t);

// SAFETY: a sigset_t is plain data.
#[cfg(unix)]
unsafe impl Send for Set {}

/// Wait for one of `set`'s signals; then remove the temporaries, say so, and exit with
/// 128 + the signal's number, as a shell reports a command killed by it.
#[cfg(unix)]
fn wait(set: Set) {
    let mut sig: libc::c_int = 0;
    // SAFETY: `set` is initialised and `sig` is a valid out-pointer.
    if unsafe { libc::sigwait(&set.0, &mut sig) } != 0 {
        return;
    }
    let removed = render::output::remove_temporaries();
    let name = match sig {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        _ => "SIGHUP",
    };
    eprintln!(
        "error: interrupted by {name}{}",
        if removed > 0 {
            "; its temporary files were removed"
        } else {
            ""
        }
    );
    std::process::exit(128 + sig);
}
