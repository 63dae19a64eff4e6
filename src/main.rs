use std::process::ExitCode;

mod bench;
mod cli;

fn main() -> ExitCode {
    cli::twin::take_over();
    end_quietly_on_a_closed_pipe();
    clean_up_when_stopped();
    cli::run()
}

/// SIGTERM (a farm scheduler's cancel or time limit), SIGINT (Ctrl-C) and SIGHUP stop the
/// run as they would, but first let the outputs being written finish (or remove them
/// under their temporary names): the frames already written stay, and no hidden `.tmp`
/// is left behind (a resume
/// would remove it, a user looking at the folder would not know to). Handled on a thread
/// of its own (signal-hook's self-pipe), where removing files is allowed; the children a
/// bench starts get the default dispositions back when they exec.
fn clean_up_when_stopped() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGTERM, SIGINT, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            // A frame's outputs take well under a second to write; a scheduler gives
            // tens of seconds between SIGTERM and SIGKILL.
            activeskin::io::remove_temporaries(std::time::Duration::from_secs(3));
            // Ends the process as the signal's default action does (its exit status).
            let _ = signal_hook::low_level::emulate_default_handler(signal);
            std::process::exit(128 + signal);
        }
    });
}

/// Rust starts with SIGPIPE ignored, so printing into a closed pipe (`activeskin info
/// f.vdb | head -1`) panics; a command-line tool ends quietly instead, as C tools do. The
/// process writes to no pipe of its own (its children's output is read, never written).
fn end_quietly_on_a_closed_pipe() {
    // SAFETY: first thing in main, before any thread; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
