//! The output folder: everything is written into a temporary folder next to the target and
//! moved into place only when the whole run has been written.
//!
//! Rules (also in `dth run --help`):
//! - the target's parent folders are created if missing;
//! - a target that exists is written into only if it is empty or holds the marker file
//!   [`MARKER`] that every dth output folder contains (so `--out ~` cannot touch a home
//!   folder); otherwise the run is refused before it starts ([`Error::OutputRefused`]); so
//!   is one that holds the scene being run ([`check_outside`]);
//! - the marker is also the folder's manifest: the names of the entries dth wrote there
//!   and whether that run was complete ([`Manifest`]). A rerun removes only the entries the
//!   previous manifest lists and leaves everything else (a user's `my_notes.txt`, `myplots/`)
//!   where it is. A user's entry with the name of a new output file is never overwritten: the
//!   rerun is refused at the end instead ([`Error::OutputRefused`]), with the target as it
//!   was;
//! - the swap, once the new output is complete in the temporary folder, moves the old
//!   listed entries (the marker first) into a second hidden folder `.NAME.old-*` beside the
//!   target, moves the new entries in (the new marker last) and removes both hidden folders.
//!   Each move is a rename within one file system: the swap takes milliseconds whatever the
//!   size of the output. A process killed during those renames leaves the previous output
//!   in `.NAME.old-*` and the target without a marker, which the next run refuses to touch
//!   rather than guess about;
//! - a run that did not complete (interrupted by SIGINT or SIGTERM, a method that failed
//!   mid-run, the thesis's figures not drawn) does not replace a complete earlier result:
//!   it is written beside it, to the dth output folder `NAME.incomplete` (replaced by the next
//!   incomplete run; [`Staging::destination`]), and the command says where. Over an earlier
//!   incomplete result, or into a new or empty target, it is written to the target itself;
//! - on any failure before the swap the old folder is untouched and the temporary folder is
//!   removed; a process that must exit at once (a second signal, or a signal outside a run)
//!   leaves nothing behind: the `dth` command's signal handler calls [`remove_live_staging`]
//!   before exiting.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use tempfile::TempDir;

use crate::error::Error;

/// Name of the marker file in every output folder; it holds the folder's [`Manifest`].
pub const MARKER: &str = ".dth-output";

/// The suffix of the folder an incomplete run is written to when the target holds a complete
/// result (`out` -> `out.incomplete`).
pub const INCOMPLETE_SUFFIX: &str = ".incomplete";

/// First line of the marker file.
const MARKER_HEADER: &str =
    "written by the dth command; a rerun removes only the entries listed here";

/// What a dth output folder's marker file says: the entries dth wrote there and whether the
/// run that wrote them was complete.
///
/// The file is plain text: a header line, `state = complete` or `state = incomplete`, then one
/// `entry = NAME` line per top-level file or folder dth wrote. A marker written before the
/// manifest existed holds only a line of text: [`Manifest::entries`] is then `None` (which
/// entries are dth's is unknown), and such a folder counts as complete.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Manifest {
    /// `true` when the run that wrote the folder computed everything its scene asked for.
    pub complete: bool,
    /// The top-level entries dth wrote (the marker itself not included); `None` for a
    /// marker without a list.
    pub entries: Option<BTreeSet<String>>,
}

impl Manifest {
    /// The marker file's text.
    pub fn render(&self) -> String {
        let mut s = format!(
            "{MARKER_HEADER}\nstate = {}\n",
            if self.complete {
                "complete"
            } else {
                "incomplete"
            }
        );
        for e in self.entries.iter().flatten() {
            s.push_str("entry = ");
            s.push_str(e);
            s.push('\n');
        }
        s
    }

    /// Reads a marker file's text (see the type's docs for the format).
    pub fn parse(text: &str) -> Manifest {
        let mut complete = true;
        let mut entries: Option<BTreeSet<String>> = None;
        for line in text.lines() {
            if let Some(state) = line.strip_prefix("state = ") {
                complete = state.trim() != "incomplete";
                entries.get_or_insert_with(BTreeSet::new);
            } else if let Some(name) = line.strip_prefix("entry = ") {
                entries
                    .get_or_insert_with(BTreeSet::new)
                    .insert(name.to_string());
            }
        }
        Manifest { complete, entries }
    }

    /// The manifest of the dth output folder `dir`, `None` when it has no marker.
    pub fn read(dir: &Path) -> Result<Option<Manifest>, Error> {
        let marker = dir.join(MARKER);
        if !marker.is_file() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&marker).map_err(io("cannot read", &marker))?;
        Ok(Some(Manifest::parse(&text)))
    }
}

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

    /// Where [`Staging::commit`] puts the output of a run that is `complete` or not: the
    /// target, except for an incomplete run over a complete earlier result, which goes
    /// beside it to `NAME.incomplete` (see the module docs).
    pub fn destination(&self, complete: bool) -> Result<PathBuf, Error> {
        if complete {
            return Ok(self.target.clone());
        }
        Ok(match Manifest::read(&self.target)? {
            Some(m) if m.complete => incomplete_path(&self.target),
            _ => self.target.clone(),
        })
    }

    /// Writes the manifest, moves the finished output into place at
    /// [`Staging::destination`] (replacing only the entries the previous output there
    /// listed) and returns where it is.
    pub fn commit(mut self, complete: bool) -> Result<PathBuf, Error> {
        let dest = self.destination(complete)?;
        check_target(&dest)?;
        let Some(tmp) = self.tmp.take() else {
            return Ok(dest);
        };
        let entries = names(tmp.path())?;
        let marker = tmp.path().join(MARKER);
        let manifest = Manifest {
            complete,
            entries: Some(entries),
        };
        std::fs::write(&marker, manifest.render()).map_err(io("cannot write", &marker))?;
        let tmp = tmp.keep();
        live().retain(|(p, _)| *p != tmp);
        let moved = if is_empty_dir(&dest) {
            std::fs::remove_dir(&dest)
                .and_then(|()| std::fs::rename(&tmp, &dest))
                .map_err(io("cannot move the output into place at", &dest))
        } else if dest.exists() {
            swap(&tmp, &dest)
        } else {
            std::fs::rename(&tmp, &dest).map_err(io("cannot move the output into place at", &dest))
        };
        if tmp.exists() {
            // After a swap, empty; after a failure, the new output, which is not kept.
            let _ = std::fs::remove_dir_all(&tmp);
        }
        moved.map(|()| dest)
    }
}

/// `out` -> `out.incomplete`: where an incomplete run goes when `out` holds a complete one.
pub fn incomplete_path(target: &Path) -> PathBuf {
    let mut name = target.file_name().unwrap_or_default().to_os_string();
    name.push(INCOMPLETE_SUFFIX);
    target.with_file_name(name)
}

fn is_empty_dir(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|mut e| e.next().is_none())
}

/// The names of the entries of `dir`, the marker excepted.
fn names(dir: &Path) -> Result<BTreeSet<String>, Error> {
    let mut names = BTreeSet::new();
    for entry in std::fs::read_dir(dir).map_err(io("cannot read", dir))? {
        let entry = entry.map_err(io("cannot read", dir))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name != MARKER {
            names.insert(name);
        }
    }
    Ok(names)
}

/// Renames done so far, undone in reverse order when a later one fails.
struct Moves(Vec<(PathBuf, PathBuf)>);

impl Moves {
    fn mv(&mut self, from: PathBuf, to: PathBuf) -> Result<(), Error> {
        match std::fs::rename(&from, &to) {
            Ok(()) => {
                self.0.push((from, to));
                Ok(())
            }
            Err(source) => {
                self.undo();
                Err(Error::Io {
                    what: "cannot move",
                    path: from,
                    source,
                })
            }
        }
    }

    fn undo(&mut self) {
        while let Some((from, to)) = self.0.pop() {
            let _ = std::fs::rename(&to, &from);
        }
    }
}

/// Replaces the entries of the dth output folder `dest` that its manifest lists by those of
/// the finished output `tmp` (see the module docs); every other entry of `dest` stays.
fn swap(tmp: &Path, dest: &Path) -> Result<(), Error> {
    let old = Manifest::read(dest)?.ok_or_else(|| Error::OutputRefused {
        path: dest.to_path_buf(),
        reason: "it is not a dth output folder (no .dth-output marker)".into(),
    })?;
    let present = names(dest)?;
    let new = names(tmp)?;
    // A marker without a list: the entries with the names of new outputs are dth's.
    let listed = old.entries.unwrap_or_else(|| new.clone());
    let ours: Vec<&String> = present.intersection(&listed).collect();
    let clash: Vec<&str> = new
        .iter()
        .filter(|n| present.contains(*n) && !listed.contains(*n))
        .map(String::as_str)
        .collect();
    if !clash.is_empty() {
        return Err(Error::OutputRefused {
            path: dest.to_path_buf(),
            reason: format!(
                "it holds {} that dth did not write (not in its manifest) under the name of a new output file; move {} or choose another --out",
                clash.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", "),
                if clash.len() == 1 { "it" } else { "them" }
            ),
        });
    }
    let parent = tmp.parent().unwrap_or(Path::new("."));
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let aside = tempfile::Builder::new()
        .prefix(&format!(".{name}.old-"))
        .tempdir_in(parent)
        .map_err(io("cannot create a folder in", parent))?
        .keep();
    let mut moves = Moves(Vec::new());
    let swapped = (|| {
        // The old marker first: from here on until the new one is in, the folder is not a
        // dth output folder, and nothing would replace it.
        moves.mv(dest.join(MARKER), aside.join(MARKER))?;
        for e in &ours {
            moves.mv(dest.join(e), aside.join(e))?;
        }
        for e in &new {
            moves.mv(tmp.join(e), dest.join(e))?;
        }
        moves.mv(tmp.join(MARKER), dest.join(MARKER))
    })();
    if swapped.is_ok() {
        std::fs::remove_dir_all(&aside).map_err(io("cannot remove the previous output", &aside))?;
    } else {
        let _ = std::fs::remove_dir(&aside);
    }
    swapped
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
        s.commit(true)?;
        assert_eq!(std::fs::read_to_string(target.join("x.txt"))?, "1");
        // Replaced after success.
        let s = Staging::new(&target)?;
        std::fs::write(s.path().join("y.txt"), "2")?;
        s.commit(true)?;
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

    fn write(s: &Staging, name: &str, text: &str) -> std::io::Result<()> {
        std::fs::write(s.path().join(name), text)
    }

    #[test]
    fn a_rerun_removes_only_what_dth_wrote() -> Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let target = dir.path().join("out");
        let s = Staging::new(&target)?;
        write(&s, "a.csv", "1")?;
        write(&s, "b.csv", "1")?;
        std::fs::create_dir(s.path().join("figs"))?;
        s.commit(true)?;
        let manifest = Manifest::read(&target)?.ok_or("no manifest")?;
        assert!(manifest.complete);
        let listed: Vec<&str> = manifest
            .entries
            .iter()
            .flatten()
            .map(String::as_str)
            .collect();
        assert_eq!(listed, ["a.csv", "b.csv", "figs"]);
        // The user's own file and folder, kept in the output folder.
        std::fs::write(target.join("my_notes.txt"), "mine")?;
        std::fs::create_dir(target.join("myplots"))?;
        std::fs::write(target.join("myplots/p.png"), "mine")?;
        let s = Staging::new(&target)?;
        write(&s, "a.csv", "2")?;
        s.commit(true)?;
        let mut left: Vec<String> = names(&target)?.into_iter().collect();
        left.sort();
        assert_eq!(left, ["a.csv", "my_notes.txt", "myplots"]);
        assert_eq!(std::fs::read_to_string(target.join("a.csv"))?, "2");
        assert_eq!(
            std::fs::read_to_string(target.join("myplots/p.png"))?,
            "mine"
        );
        // A user's file under the name of a new output is not overwritten: refused, target
        // as it was, no hidden folder left.
        std::fs::write(target.join("c.csv"), "mine")?;
        let s = Staging::new(&target)?;
        write(&s, "a.csv", "3")?;
        write(&s, "c.csv", "3")?;
        assert!(matches!(s.commit(true), Err(Error::OutputRefused { .. })));
        assert_eq!(std::fs::read_to_string(target.join("c.csv"))?, "mine");
        assert_eq!(std::fs::read_to_string(target.join("a.csv"))?, "2");
        assert_eq!(std::fs::read_dir(dir.path())?.count(), 1);
        Ok(())
    }

    #[test]
    fn an_incomplete_rerun_keeps_the_complete_result() -> Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let target = dir.path().join("out");
        let s = Staging::new(&target)?;
        write(&s, "a.csv", "complete")?;
        s.commit(true)?;
        let s = Staging::new(&target)?;
        write(&s, "a.csv", "partial")?;
        assert_eq!(s.destination(false)?, dir.path().join("out.incomplete"));
        assert_eq!(s.commit(false)?, dir.path().join("out.incomplete"));
        assert_eq!(std::fs::read_to_string(target.join("a.csv"))?, "complete");
        let partial = dir.path().join("out.incomplete");
        assert_eq!(std::fs::read_to_string(partial.join("a.csv"))?, "partial");
        assert_eq!(Manifest::read(&partial)?.map(|m| m.complete), Some(false));
        // A second incomplete run replaces the first incomplete one, not the complete one.
        let s = Staging::new(&target)?;
        write(&s, "a.csv", "partial 2")?;
        s.commit(false)?;
        assert_eq!(std::fs::read_to_string(partial.join("a.csv"))?, "partial 2");
        assert_eq!(std::fs::read_to_string(target.join("a.csv"))?, "complete");
        // Into an incomplete result, an incomplete run goes to the target itself.
        let other = dir.path().join("other");
        for text in ["partial", "partial 2"] {
            let s = Staging::new(&other)?;
            write(&s, "a.csv", text)?;
            assert_eq!(s.commit(false)?, other);
        }
        assert_eq!(std::fs::read_to_string(other.join("a.csv"))?, "partial 2");
        Ok(())
    }

    #[test]
    fn a_marker_without_a_list_replaces_only_same_named_entries() {
        let m = Manifest::parse("written by the dth command\n");
        assert!(m.complete && m.entries.is_none());
        let m = Manifest {
            complete: false,
            entries: Some(["x.csv".to_string()].into()),
        };
        assert_eq!(Manifest::parse(&m.render()), m);
    }
}
