//! What every reader and writer shares: extensions, one-line errors, regular files read
//! whole, and writes under a temporary name renamed into place.

use std::path::{Path, PathBuf};

/// A file that could not be written: the file, and the cause.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct WriteError {
    /// The file being written.
    pub path: PathBuf,
    #[source]
    /// Why it failed.
    pub source: std::io::Error,
}

/// Whether `path`'s extension is one of `extensions` (lowercase), in any case.
pub fn has_extension(path: &Path, extensions: &[&str]) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| extensions.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// An error and its causes on one line, `error: cause: cause` (a cause whose text is
/// already there is not repeated).
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        let more = cause.to_string();
        if !text.contains(&more) {
            text = format!("{text}: {more}");
        }
        source = cause.source();
    }
    printable(&text, ERROR_CHARS)
}

/// The most characters [`error_chain`] gives one error: paths and a reason fit; a file's
/// bytes echoed by a message do not.
const ERROR_CHARS: usize = 600;

/// `text` on one printable line of at most `most` characters: control characters (a
/// newline, a NUL from a binary file) escaped as Rust writes them, the rest cut with `…`.
pub fn printable(text: &str, most: usize) -> String {
    let mut out = String::new();
    for (n, c) in text.chars().enumerate() {
        if n == most {
            out.push('…');
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

/// The temporary name a file is written under before being renamed to `path`: hidden,
/// in the same folder (so the rename is atomic), unique to this process.
pub fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Why `path` cannot be read as a file, when it exists but is not one (a directory, a
/// named pipe, which would block a reader until something writes to it, a socket or a
/// device) or cannot be looked at (a symlink loop, no permission); `None` when it is a
/// regular file or does not exist. Asks the file system only: nothing is opened.
pub fn not_a_file(path: &Path) -> Option<String> {
    use std::os::unix::fs::FileTypeExt;
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => None,
        Ok(m) => {
            let t = m.file_type();
            let kind = if t.is_dir() {
                "a directory"
            } else if t.is_fifo() {
                "a named pipe (FIFO)"
            } else if t.is_socket() {
                "a socket"
            } else {
                "a device"
            };
            Some(format!("is {kind}, not a file"))
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => Some(format!("cannot be read: {e}")),
    }
}

/// A regular file's bytes. Opened without waiting (a named pipe would block until
/// something writes to it), its type checked on the open file (no race with a rename),
/// then read: a device (`/dev/zero`) or a pipe is refused before any byte is read.
pub fn read_regular(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    use std::os::unix::fs::OpenOptionsExt;
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        let why = not_a_file(path).unwrap_or_else(|| "is not a regular file".into());
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, why));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// Runs `write` on a temporary path, then renames it to `path`. On any failure the
/// temporary file is removed and `path` is left as it was. A `path` that exists and is
/// not a regular file — `/dev/null`, a named pipe, a device — is written in place: renamed
/// over, `--stats /dev/null` run as root would have replaced the device with a file.
/// The writer's own error type is kept; the rename's failure becomes one of it.
pub fn write_atomically<E, F>(path: &Path, write: F) -> Result<(), E>
where
    E: From<std::io::Error>,
    F: FnOnce(&Path) -> Result<(), E>,
{
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        return write(path);
    }
    let tmp = temporary_path(path);
    let _registered = Writing::register(&tmp);
    let result = write(&tmp).and_then(|()| std::fs::rename(&tmp, path).map_err(E::from));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The temporaries being written now (by any thread), for [`remove_temporaries`].
static WRITING: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
/// Signalled each time a temporary is renamed or removed (its [`Writing`] dropped).
static WRITTEN: std::sync::Condvar = std::sync::Condvar::new();
/// Set once the process is stopping: no new temporary is started after it.
static STOPPING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// A temporary listed in [`WRITING`] while it lives.
struct Writing(PathBuf);

impl Writing {
    fn register(tmp: &Path) -> Self {
        let mut list = writing();
        if STOPPING.load(std::sync::atomic::Ordering::SeqCst) {
            // The process is about to exit: this output is not started (and so cannot be
            // left half-written under its temporary name); the thread waits for the end.
            drop(list);
            loop {
                std::thread::park();
            }
        }
        list.push(tmp.to_path_buf());
        Writing(tmp.to_path_buf())
    }
}

impl Drop for Writing {
    fn drop(&mut self) {
        let mut list = writing();
        if let Some(at) = list.iter().position(|p| *p == self.0) {
            list.swap_remove(at);
        }
        WRITTEN.notify_all();
    }
}

/// The list, even after a writer panicked while holding it (it only adds and removes).
fn writing() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    WRITING
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// For a process stopped by a signal (SIGTERM from a farm's scheduler, Ctrl-C): no new
/// output is started, the ones being written are given up to `grace` to finish (renamed
/// whole to their names), and the temporaries of those that did not are removed, so that
/// no hidden `.tmp` is left behind. Removing a temporary as soon as the signal came would
/// race its writer, which may create it a moment later. Call it once, just before exiting.
pub fn remove_temporaries(grace: std::time::Duration) {
    STOPPING.store(true, std::sync::atomic::Ordering::SeqCst);
    let list = writing();
    let (mut list, _) = WRITTEN
        .wait_timeout_while(list, grace, |list| !list.is_empty())
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    // A writer still going after the grace has long created its temporary.
    for tmp in list.drain(..) {
        let _ = std::fs::remove_file(tmp);
    }
    // The guard is leaked so that no writer takes the list again before the exit.
    std::mem::forget(list);
}

/// A new file whose bytes are handed to the kernel's writeback every few megabytes as they
/// are written, so that the sync closing it waits for the last few only.
pub struct EagerWriteback {
    file: std::fs::File,
    written: u64,
    handed: u64,
}

impl EagerWriteback {
    pub fn create(path: &Path) -> std::io::Result<Self> {
        Ok(EagerWriteback {
            file: std::fs::File::create(path)?,
            written: 0,
            handed: 0,
        })
    }

    /// Flushes nothing (it buffers nothing) and waits until the file is on disk.
    pub fn sync(&self) -> std::io::Result<()> {
        self.file.sync_all()
    }
}

impl std::io::Write for EagerWriteback {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(bytes)?;
        self.written += n as u64;
        const STEP: u64 = 8 << 20;
        if self.written - self.handed >= STEP {
            #[cfg(target_os = "linux")]
            {
                use std::os::fd::AsRawFd;
                // SAFETY: a plain system call on our own open descriptor; a failure only
                // leaves the writeback to the final sync.
                unsafe {
                    libc::sync_file_range(
                        self.file.as_raw_fd(),
                        self.handed as i64,
                        (self.written - self.handed) as i64,
                        libc::SYNC_FILE_RANGE_WRITE,
                    );
                }
            }
            self.handed = self.written;
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A named pipe stays a pipe, and its reader gets the bytes (as /dev/null must stay
    /// a device).
    #[test]
    fn printable_escapes_control_characters_and_cuts_long_text() {
        assert_eq!(printable("a\nb\0c\u{7f}é", 100), "a\\nb\\u{0}c\\u{7f}é");
        assert_eq!(printable("abcdef", 3), "abc…");
        assert_eq!(printable("abc", 3), "abc");
    }

    #[test]
    fn special_files_are_written_in_place_not_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("stats.pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("no mkfifo here: skipped");
            return;
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        write_atomically(&fifo, |p| std::fs::write(p, b"frame 1")).unwrap();
        assert_eq!(reader.join().unwrap(), b"frame 1");
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // /dev/null itself, when there is one: still a character device afterwards.
        let null = Path::new("/dev/null");
        if std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
            write_atomically(null, |p| std::fs::write(p, b"x")).unwrap();
            assert!(std::fs::metadata(null)
                .unwrap()
                .file_type()
                .is_char_device());
        }
    }

    /// An injected failing writer (a disk that fills up half-way): the earlier file
    /// stays as it was and no temporary is left.
    #[test]
    fn a_writer_failing_half_way_leaves_the_earlier_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.0001.vdb");
        std::fs::write(&path, b"the earlier, whole frame").unwrap();
        let result = write_atomically(&path, |tmp| {
            std::fs::write(tmp, b"half a fr")?;
            Err(std::io::Error::from_raw_os_error(28))
        });
        assert_eq!(result.unwrap_err().raw_os_error(), Some(28));
        assert_eq!(std::fs::read(&path).unwrap(), b"the earlier, whole frame");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "a temporary file was left");
    }

    /// Bytes handed to writeback along the way are the bytes read back, in order.
    #[test]
    fn eager_writeback_writes_every_byte() {
        use std::io::Write;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.bin");
        let bytes: Vec<u8> = (0..20_000_003u32)
            .map(|i| (i * 7 + i / 4096) as u8)
            .collect();
        let mut w = std::io::BufWriter::new(EagerWriteback::create(&path).unwrap());
        for part in bytes.chunks(1_500_007) {
            w.write_all(part).unwrap();
        }
        w.flush().unwrap();
        assert!(w.get_ref().handed > 0 && w.get_ref().handed < w.get_ref().written);
        w.get_ref().sync().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
    }
}
