use std::process::ExitCode;

mod cli;

fn main() -> ExitCode {
    end_quietly_on_a_closed_pipe();
    cli::run()
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
