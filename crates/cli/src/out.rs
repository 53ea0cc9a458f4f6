//! Where the command's bytes go: standard output that tolerates a closed pipe, messages on
//! standard error that never panic, output files checked before any work, and temporaries
//! removed when a signal stops the process.

use std::io::{self, Write};
use std::path::Path;

use anyhow::bail;

/// Prints a line on standard error; a failing standard error is ignored (it has nowhere to go).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($t)*);
    }};
}

/// Runs `f` on buffered, locked standard output, then flushes it. A reader that closed the pipe
/// makes this fail with [`io::ErrorKind::BrokenPipe`], which `main` turns into a quiet success.
pub fn stdout(f: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> io::Result<()> {
    let mut w = io::BufWriter::new(io::stdout().lock());
    f(&mut w)?;
    w.flush()
}

/// Whether `err` comes from writing to a closed pipe.
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    let epipe = |e: &(dyn std::error::Error + 'static)| {
        e.downcast_ref::<io::Error>().is_some_and(|e| e.kind() == io::ErrorKind::BrokenPipe)
    };
    err.chain().any(|e| {
        // The readers' error keeps its cause in a field (its text is already in the message).
        let inner = e.downcast_ref::<octowrap_io::Error>().and_then(|e| e.source.as_deref());
        epipe(e) || inner.is_some_and(|s| epipe(s))
    })
}

/// How to treat an existing output file; shared by every subcommand that writes one.
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct ClobberArgs {
    /// Refuse to replace an existing output file (checked before any work).
    #[arg(long)]
    pub no_clobber: bool,
}

impl ClobberArgs {
    /// The file-writing options these arguments stand for.
    pub fn write_options(self) -> octowrap_fsutil::WriteOptions {
        octowrap_fsutil::WriteOptions::no_clobber(self.no_clobber)
    }
}

/// Checks, before any work, that `output` can be written: not a folder, its folder exists, not an
/// existing file with `--no-clobber`, and not one of `inputs` (the same file by device and inode,
/// so also through symbolic or hard links). `-` (standard output) always can.
pub fn check_output(output: &Path, inputs: &[&Path], clobber: ClobberArgs) -> anyhow::Result<()> {
    if output == Path::new("-") {
        return Ok(());
    }
    for input in inputs {
        if *input != Path::new("-") && octowrap_fsutil::same_file(input, output) {
            bail!(
                "{}: the output is the input {} (the same file): write the output to another file",
                output.display(),
                input.display()
            );
        }
    }
    if let Err(e) = octowrap_fsutil::check_output(output, &clobber.write_options()) {
        if e.kind() == io::ErrorKind::AlreadyExists {
            bail!("{}: the output exists, and --no-clobber forbids replacing it", output.display());
        }
        bail!("{}: cannot write the output: {e}", output.display());
    }
    Ok(())
}

/// Makes SIGINT and SIGTERM remove the temporary files of writes in progress, then end the
/// process with 130 or 143 (128 plus the signal number, as shells report it).
pub fn remove_temporaries_on_signals() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else { return };
        std::thread::spawn(move || {
            if let Some(sig) = signals.forever().next() {
                octowrap_fsutil::remove_temporaries_before_exit();
                std::process::exit(128 + sig);
            }
        });
    }
}
