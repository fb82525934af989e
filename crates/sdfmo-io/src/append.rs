//! Append-only logs of one-line records (the sweep's per-shard ledgers): each record is one
//! `write` of its bytes and a newline, synced before [`AppendLog::append`] returns, so a crash
//! or a kill leaves every earlier record whole and at most a torn last line, which
//! [`AppendLog::open`] drops.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::{os, FileKind, IoError, Result};

/// An append-only file of newline-terminated records.
#[derive(Debug)]
pub struct AppendLog {
    file: File,
    path: PathBuf,
}

impl AppendLog {
    /// Opens the log at `path` (a name the command derived, inside its output folder), creating
    /// it when missing, and returns it with its complete records' bytes (every byte up to and
    /// including the last newline). A torn last line, left by a crash in the middle of an
    /// append, is cut off the file, so the next record starts on a line of its own.
    ///
    /// A symbolic link at `path` is refused rather than followed (it could lead appends to a
    /// file the user never named), and so is anything but a regular file. So is a file with
    /// more than one name (a hard link, which `O_NOFOLLOW` does not stop): the log is truncated
    /// and appended to in place, which would change the file at its other names.
    ///
    /// # Errors
    /// [`IoError::NotRegularFile`] (a link, a directory, a device, a FIFO),
    /// [`IoError::HardLinked`], [`IoError::TooLarge`] when the log holds more than `limit`
    /// bytes, [`IoError::Os`].
    pub fn open(path: &Path, limit: u64) -> Result<(AppendLog, Vec<u8>)> {
        match std::fs::symlink_metadata(path) {
            Ok(meta) if !meta.is_file() => {
                return Err(IoError::NotRegularFile {
                    path: path.to_path_buf(),
                    kind: if meta.file_type().is_symlink() {
                        FileKind::Other
                    } else {
                        FileKind::of(&meta)
                    },
                    action: "appended to",
                })
            }
            _ => {}
        }
        let mut opts = OpenOptions::new();
        opts.read(true).append(true).create(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            opts.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
        }
        let mut file = opts.open(path).map_err(os("open", path))?;
        let meta = file.metadata().map_err(os("read", path))?;
        if !meta.is_file() {
            return Err(IoError::NotRegularFile {
                path: path.to_path_buf(),
                kind: FileKind::of(&meta),
                action: "appended to",
            });
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            if meta.nlink() > 1 {
                return Err(IoError::HardLinked {
                    path: path.to_path_buf(),
                    links: meta.nlink(),
                });
            }
        }
        if meta.len() > limit {
            return Err(IoError::TooLarge {
                path: path.to_path_buf(),
                size: meta.len(),
                limit,
            });
        }
        let mut bytes = Vec::with_capacity(meta.len() as usize);
        file.seek(SeekFrom::Start(0)).map_err(os("read", path))?;
        (&mut file)
            .take(limit + 1)
            .read_to_end(&mut bytes)
            .map_err(os("read", path))?;
        let complete = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        if complete < bytes.len() {
            file.set_len(complete as u64)
                .map_err(os("truncate", path))?;
            file.sync_all().map_err(os("sync", path))?;
            bytes.truncate(complete);
        }
        Ok((
            AppendLog {
                file,
                path: path.to_path_buf(),
            },
            bytes,
        ))
    }

    /// Appends `record` and a newline in one write, then syncs the file's data.
    ///
    /// # Errors
    /// [`IoError::Os`] when the write or the sync fails (a full disk), or of kind
    /// `InvalidInput` when `record` holds a newline (it would be two records).
    pub fn append(&mut self, record: &[u8]) -> Result<()> {
        if record.contains(&b'\n') {
            return Err(IoError::Os {
                action: "append a record holding a newline to",
                path: self.path.clone(),
                source: std::io::Error::from(std::io::ErrorKind::InvalidInput),
            });
        }
        let mut line = Vec::with_capacity(record.len() + 1);
        line.extend_from_slice(record);
        line.push(b'\n');
        self.file
            .write_all(&line)
            .map_err(os("append to", &self.path))?;
        self.file.sync_data().map_err(os("sync", &self.path))
    }

    /// The log's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_append_and_a_torn_last_line_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("ledger.jsonl");
        let (mut log, old) = AppendLog::open(&p, 1 << 20).unwrap();
        assert!(old.is_empty());
        log.append(b"{\"a\":1}").unwrap();
        log.append(b"{\"b\":2}").unwrap();
        assert!(log.append(b"two\nlines").is_err());
        drop(log);
        // A crash in the middle of the third append.
        std::fs::OpenOptions::new()
            .append(true)
            .open(&p)
            .unwrap()
            .write_all(b"{\"c\":")
            .unwrap();
        let (mut log, old) = AppendLog::open(&p, 1 << 20).unwrap();
        assert_eq!(old, b"{\"a\":1}\n{\"b\":2}\n");
        log.append(b"{\"c\":3}").unwrap();
        assert_eq!(
            std::fs::read(&p).unwrap(),
            b"{\"a\":1}\n{\"b\":2}\n{\"c\":3}\n"
        );
        assert!(matches!(
            AppendLog::open(&p, 4),
            Err(IoError::TooLarge { .. })
        ));
    }

    #[cfg(unix)]
    #[test]
    fn links_and_special_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("elsewhere");
        std::fs::write(&target, b"x\n").unwrap();
        let link = dir.path().join("ledger.jsonl");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        assert!(matches!(
            AppendLog::open(&link, 1 << 20),
            Err(IoError::NotRegularFile { .. })
        ));
        assert!(AppendLog::open(dir.path(), 1 << 20).is_err());
        // A hard link: appending (or cutting a torn line) would change `elsewhere` too.
        std::fs::remove_file(&link).unwrap();
        std::fs::hard_link(&target, &link).unwrap();
        assert!(matches!(
            AppendLog::open(&link, 1 << 20),
            Err(IoError::HardLinked { links: 2, .. })
        ));
        assert!(AppendLog::open(Path::new("/dev/null"), 1 << 20).is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"x\n");
    }
}
