//! The output folder: everything is written into a temporary folder next to the target and
//! moved into place only when the whole run succeeded.
//!
//! Rules (also in `dth run --help`):
//! - the target's parent folders are created if missing;
//! - a target that exists is replaced only if it is empty or holds the marker file
//!   [`MARKER`] that every dth output folder contains (so `--out ~` cannot wipe a home
//!   folder); otherwise the run is refused before it starts ([`Error::OutputRefused`]); so
//!   is one that holds the scene being run ([`check_outside`]), which replacing it would
//!   delete;
//! - the old folder is swapped out only after the new one is complete: on any failure the old
//!   folder is untouched and the temporary folder is removed;
//! - a run interrupted by SIGINT or SIGTERM stops at the next step and is written and moved
//!   into place like a complete one (`crate::pipeline::RunError::Interrupted`); a process that
//!   must exit at once instead (a second signal, or a signal outside a run) leaves nothing
//!   behind: the `dth` command's signal handler calls [`remove_live_staging`] before exiting,
//!   so the old folder is untouched and no temporary folder is left.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use tempfile::TempDir;

use crate::error::Error;

/// Name of the marker file in every output folder.
pub const MARKER: &str = ".dth-output";

/// The temporary folders of the stagings alive in this process, with the outermost parent
/// folder each created (see [`remove_live_staging`]).
static LIVE: Mutex<Vec<(PathBuf, Option<PathBuf>)>> = Mutex::new(Vec::new());

fn live() -> std::sync::MutexGuard<'static, Vec<(PathBuf, Option<PathBuf>)>> {
    // A panic while holding the lock cannot leave the list inconsistent (push and retain).
    LIVE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Removes the temporary folder of every staging alive in this process (and the parent
/// folders it created, if empty), for a process about to exit on a signal: the run's partial
/// output is not kept, and no temporary folder is left. The stagings themselves are not
/// usable afterwards.
pub fn remove_live_staging() {
    for (tmp, created) in live().iter() {
        // The run may still be writing into it: retry until the folder is gone.
        for _ in 0..10 {
            if std::fs::remove_dir_all(tmp).is_ok() || !tmp.exists() {
                break;
            }
        }
        remove_empty_parents(tmp, created.as_deref());
    }
}

/// Removes the empty folders from `path`'s parent up to `top` (the outermost one a staging
/// created); stops at the first that is not empty.
fn remove_empty_parents(path: &Path, top: Option<&Path>) {
    let Some(top) = top else { return };
    let mut dir = path.parent().map(Path::to_path_buf);
    while let Some(d) = dir {
        // `remove_dir` removes only empty folders: nothing else is touched.
        if std::fs::remove_dir(&d).is_err() || d == top {
            break;
        }
        dir = d.parent().map(Path::to_path_buf);
    }
}

/// A temporary folder that becomes the output folder on [`Staging::commit`].
#[derive(Debug)]
pub struct Staging {
    tmp: Option<TempDir>,
    target: PathBuf,
    /// The outermost folder this staging created for the target's parent (removed again,
    /// if still empty, when the staging is dropped without a commit).
    created: Option<PathBuf>,
}

impl Drop for Staging {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let path = tmp.path().to_path_buf();
            drop(tmp);
            live().retain(|(p, _)| *p != path);
            remove_empty_parents(&self.target, self.created.as_deref());
        }
    }
}

fn io<'a>(what: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> Error + 'a {
    move |source| Error::Io {
        what,
        path: path.to_path_buf(),
        source,
    }
}

/// Checks that `target` may be (re)placed, without touching it.
pub fn check_target(target: &Path) -> Result<(), Error> {
    let refuse = |reason: &str| Error::OutputRefused {
        path: target.to_path_buf(),
        reason: reason.to_string(),
    };
    if target.file_name().is_none() {
        return Err(refuse("expected a folder name, e.g. `dth-out/run1`"));
    }
    match std::fs::symlink_metadata(target) {
        Err(_) => Ok(()),
        Ok(m) if !m.is_dir() => Err(refuse("it exists and is not a folder")),
        Ok(_) => {
            let mut entries = std::fs::read_dir(target).map_err(io("cannot read", target))?;
            if entries.next().is_none() || target.join(MARKER).is_file() {
                Ok(())
            } else {
                Err(refuse(
                    "it exists and is not a dth output folder (no .dth-output marker); choose another --out or remove it",
                ))
            }
        }
    }
}

/// Refuses a `target` that holds `file` (the scene being run): replacing the target, an old
/// output folder, would delete it. A target that does not exist holds nothing.
///
/// ```
/// let dir = tempfile::tempdir()?;
/// let scene = dir.path().join("out/scene.toml");
/// std::fs::create_dir(dir.path().join("out"))?;
/// std::fs::write(&scene, "")?;
/// let refused = dth_examples::output::check_outside(&scene, &dir.path().join("out"));
/// assert!(matches!(refused, Err(dth_examples::Error::OutputRefused { .. })));
/// assert!(dth_examples::output::check_outside(&scene, &dir.path().join("other")).is_ok());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn check_outside(file: &Path, target: &Path) -> Result<(), Error> {
    let (Ok(file), Ok(folder)) = (file.canonicalize(), target.canonicalize()) else {
        return Ok(());
    };
    if file.starts_with(&folder) {
        return Err(Error::OutputRefused {
            path: target.to_path_buf(),
            reason: format!(
                "it holds the scene `{}`, which replacing the folder would delete: choose another --out or move the scene out of it",
                file.display()
            ),
        });
    }
    Ok(())
}

impl Staging {
    /// Creates the temporary folder next to `target` (after [`check_target`]).
    pub fn new(target: &Path) -> Result<Self, Error> {
        check_target(target)?;
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let created = parent
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .last()
            .map(Path::to_path_buf);
        // The output folder cannot be made here: the user's `--out` is wrong (exit code 2, as
        // for a refused folder), with the system's reason.
        let unwritable = |what: &str| {
            let target = target.to_path_buf();
            let what = what.to_string();
            move |e: std::io::Error| Error::OutputRefused {
                path: target,
                reason: format!("{what}: {e}"),
            }
        };
        std::fs::create_dir_all(&parent).map_err(unwritable(&format!(
            "cannot create its parent folder `{}`",
            parent.display()
        )))?;
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{name}.tmp-"))
            .tempdir_in(&parent)
            .map_err(unwritable(&format!(
                "cannot create a folder in `{}`",
                parent.display()
            )))?;
        live().push((tmp.path().to_path_buf(), created.clone()));
        Ok(Staging {
            tmp: Some(tmp),
            target: target.to_path_buf(),
            created,
        })
    }

    /// Where to write.
    pub fn path(&self) -> &Path {
        match &self.tmp {
            Some(t) => t.path(),
            None => &self.target,
        }
    }

    /// The final location.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Moves the finished folder into place (replacing an old output folder) and returns it.
    pub fn commit(mut self) -> Result<PathBuf, Error> {
        let marker = self.path().join(MARKER);
        std::fs::write(&marker, "written by the dth command\n")
            .map_err(io("cannot write", &marker))?;
        check_target(&self.target)?;
        let old = if self.target.exists() {
            let name = self.path().with_extension("old");
            std::fs::rename(&self.target, &name).map_err(io("cannot move aside", &self.target))?;
            Some(name)
        } else {
            None
        };
        let Some(tmp) = self.tmp.take() else {
            return Ok(self.target.clone());
        };
        let tmp = tmp.keep();
        live().retain(|(p, _)| *p != tmp);
        if let Err(source) = std::fs::rename(&tmp, &self.target) {
            if let Some(old) = &old {
                let _ = std::fs::rename(old, &self.target);
            }
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(Error::Io {
                what: "cannot move the output into place at",
                path: self.target.clone(),
                source,
            });
        }
        if let Some(old) = old {
            std::fs::remove_dir_all(&old).map_err(io("cannot remove the previous output", &old))?;
        }
        Ok(self.target.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commit_replaces_only_marked_folders() -> Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let target = dir.path().join("a/b/out");
        let s = Staging::new(&target)?;
        std::fs::write(s.path().join("x.txt"), "1")?;
        s.commit()?;
        assert_eq!(std::fs::read_to_string(target.join("x.txt"))?, "1");
        // Replaced after success.
        let s = Staging::new(&target)?;
        std::fs::write(s.path().join("y.txt"), "2")?;
        s.commit()?;
        assert!(!target.join("x.txt").exists() && target.join("y.txt").exists());
        // Dropped staging leaves the target as it was and no temporary folder.
        let s = Staging::new(&target)?;
        std::fs::write(s.path().join("z.txt"), "3")?;
        drop(s);
        assert!(target.join("y.txt").exists() && !target.join("z.txt").exists());
        let leftovers = std::fs::read_dir(target.parent().ok_or("parent")?)?.count();
        assert_eq!(leftovers, 1);
        // Parent folders created for a staging that is dropped are removed again.
        let deep = dir.path().join("x/y/z/out");
        drop(Staging::new(&deep)?);
        assert!(!dir.path().join("x").exists());
        // A foreign non-empty folder is refused.
        let foreign = dir.path().join("home");
        std::fs::create_dir(&foreign)?;
        std::fs::write(foreign.join("precious"), "")?;
        assert!(matches!(
            Staging::new(&foreign),
            Err(Error::OutputRefused { .. })
        ));
        Ok(())
    }
}
