//! Writing a file so that it is either absent, its old self, or complete: through a temporary
//! `NAME.part` beside it and a rename.
//!
//! The temporary name is never followed: whatever an earlier, killed run left there (a file,
//! or a symbolic link pointing anywhere) is removed first and the temporary file is created
//! new (`O_CREAT | O_EXCL`, which refuses to open through a link), so a stale
//! `frame_0000.obj.part -> /elsewhere` link cannot make a run overwrite `/elsewhere`. The
//! rename replaces `NAME` itself, also when `NAME` is a link. On any error the temporary file
//! is removed, so a failed write leaves no `.part` behind.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary name of `path`: `path` with `.part` appended (`frame_0001.obj.part`).
pub fn part_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".part");
    path.with_file_name(name)
}

/// Removes the file or link at `path`, if any (never what a link points to).
pub fn remove_if_present(path: &Path) -> io::Result<()> {
    match fs::remove_file(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    }
}

/// Creates a new file at `path`, replacing a file or link of that name (never following a
/// link).
pub fn create_fresh(path: &Path) -> io::Result<File> {
    remove_if_present(path)?;
    OpenOptions::new().write(true).create_new(true).open(path)
}

/// Writes `path` through [`part_path`] and a rename: `write` fills a buffered writer, which is
/// flushed; the rename happens only when everything succeeded. On failure the temporary file
/// is removed and `path` is left as it was.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let part = part_path(path);
    let file = create_fresh(&part)?;
    let mut w = BufWriter::new(file);
    let result = write(&mut w).and_then(|()| w.flush()).and_then(|()| {
        drop(w);
        fs::rename(&part, path)
    });
    if result.is_err() {
        let _ = fs::remove_file(&part);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("wetcloth-atomic-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_file_is_written_whole_and_no_part_remains() {
        let d = scratch("whole");
        let path = d.join("a.txt");
        write_atomically(&path, |w| w.write_all(b"hello\n")).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "hello\n");
        assert!(!part_path(&path).exists());
        assert_eq!(part_path(&path), d.join("a.txt.part"));
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_part() {
        let d = scratch("failed");
        let path = d.join("a.txt");
        fs::write(&path, "old").unwrap();
        let e = write_atomically(&path, |w| {
            w.write_all(b"half")?;
            Err(io::Error::other("disk full"))
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "disk full");
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        assert!(!part_path(&path).exists());
    }

    /// Found from outside: a stale `frame_0000.obj.part` symbolic link in the output folder was
    /// followed and its target overwritten.
    #[cfg(unix)]
    #[test]
    fn a_stale_part_link_is_replaced_not_followed() {
        let d = scratch("link");
        let precious = d.join("precious.txt");
        fs::write(&precious, "keep me").unwrap();
        let path = d.join("frame_0000.obj");
        std::os::unix::fs::symlink(&precious, part_path(&path)).unwrap();
        write_atomically(&path, |w| w.write_all(b"o cloth\n")).unwrap();
        assert_eq!(fs::read_to_string(&precious).unwrap(), "keep me");
        assert_eq!(fs::read_to_string(&path).unwrap(), "o cloth\n");
        assert!(fs::symlink_metadata(&path).unwrap().file_type().is_file());
        assert!(fs::symlink_metadata(part_path(&path)).is_err());
        // A dangling link, and a link at the final name itself: replaced too.
        std::os::unix::fs::symlink(d.join("nowhere"), part_path(&path)).unwrap();
        fs::remove_file(&path).unwrap();
        std::os::unix::fs::symlink(&precious, &path).unwrap();
        write_atomically(&path, |w| w.write_all(b"again\n")).unwrap();
        assert_eq!(fs::read_to_string(&precious).unwrap(), "keep me");
        assert_eq!(fs::read_to_string(&path).unwrap(), "again\n");
        assert!(!d.join("nowhere").exists());
        // create_fresh replaces a link instead of truncating its target.
        let csv = d.join("metrics.csv");
        std::os::unix::fs::symlink(&precious, &csv).unwrap();
        drop(create_fresh(&csv).unwrap());
        assert_eq!(fs::read_to_string(&precious).unwrap(), "keep me");
        assert_eq!(fs::read_to_string(&csv).unwrap(), "");
    }
}
