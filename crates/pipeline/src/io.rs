//! Files: atomic output, RON, images and globs — the one copy every command uses. Calibration
//! files in every format are read by `parallax_interop` (one reader).

use std::path::{Path, PathBuf};

use crate::{PipelineError, Result};

pub(crate) fn io_err<'a>(what: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> PipelineError + 'a {
    move |source| PipelineError::Io { what, path: path.to_path_buf(), source }
}

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, then a rename,
/// so a failed run never leaves a half-written result. Creates the parent directory. Refuses a
/// `path` that is an existing directory, and removes the temporary file on every failure.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut set = OutputSet::new();
    set.add(path, bytes)?;
    set.commit().map(|_| ())
}

/// The files one run writes, written as a set: each file is staged as it is added, in a hidden
/// temporary file beside its destination (so a run holds no image in memory to write it later),
/// and only [`OutputSet::commit`] renames them all into place. A set dropped without a commit
/// (an error, a refusal, a panic) removes its temporary files and the folders it made, so a
/// failed run leaves no file, new or changed. Adding refuses a destination that is an existing
/// directory or has no file name. (A rename can still fail half-way — a permission change in
/// the meantime — and the error then names the files already replaced.)
#[derive(Debug, Default)]
pub struct OutputSet {
    /// Destination and its staged temporary file, in the order added.
    files: Vec<(PathBuf, PathBuf)>,
    /// Folders made for the set, outermost first.
    created: Vec<PathBuf>,
    /// Files of an earlier run that this set replaces as a whole ([`OutputSet::supersede`]).
    superseded: Vec<PathBuf>,
    /// Folders whose killed runs' commits were finished ([`finish_killed_commits`], once each).
    finished: Vec<PathBuf>,
    committed: bool,
}

impl OutputSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Stages a file (replacing what an earlier `add` gave the same path).
    pub fn add(&mut self, path: impl Into<PathBuf>, bytes: impl AsRef<[u8]>) -> Result<()> {
        let path = path.into();
        if path.is_dir() {
            return Err(PipelineError::Input(format!(
                "{} is a directory: give a file name (e.g. {})",
                path.display(),
                path.join("result.ron").display()
            )));
        }
        let name = path
            .file_name()
            .ok_or_else(|| PipelineError::Input(format!("{} has no file name", path.display())))?
            .to_string_lossy()
            .into_owned();
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
        let mut missing: Vec<PathBuf> = dir.ancestors().take_while(|a| !a.exists()).map(Path::to_path_buf).collect();
        missing.reverse();
        std::fs::create_dir_all(&dir).map_err(io_err("creating directory", &dir))?;
        self.created.extend(missing);
        // a killed run's commit is finished before its staged files would count as leftovers
        if !self.finished.contains(&dir) {
            finish_killed_commits(&dir);
            remove_dead_runs_temps(&dir);
            self.finished.push(dir.clone());
        }
        let k = match self.files.iter().position(|(p, _)| *p == path) {
            Some(k) => k,
            None => {
                // the index keeps two outputs of one set with the same name apart
                let tmp = dir.join(format!(".{name}.tmp{}-{}", std::process::id(), self.files.len()));
                self.files.push((path, tmp));
                self.files.len() - 1
            }
        };
        let tmp = &self.files[k].1;
        if let Err(e) = std::fs::write(tmp, bytes.as_ref()).map_err(io_err("writing", tmp)) {
            let _ = std::fs::remove_file(tmp);
            self.files.remove(k);
            return Err(e);
        }
        Ok(())
    }

    /// Stages an image encoded as PNG.
    pub fn add_png<P, C>(&mut self, path: impl Into<PathBuf>, img: &image::ImageBuffer<P, C>) -> Result<()>
    where
        P: image::PixelWithColorType,
        [P::Subpixel]: image::EncodableLayout,
        C: std::ops::Deref<Target = [P::Subpixel]>,
    {
        self.add(path, png_bytes(img)?)
    }

    /// Stages `value` as pretty RON.
    pub fn add_ron<T: serde::Serialize>(&mut self, path: impl Into<PathBuf>, value: &T) -> Result<()> {
        self.add(path, to_ron(value)?)
    }

    /// Stages a result in its format (see [`write_result`]); returns the paths it takes (two
    /// for the calibration formats that write a file per camera).
    pub fn add_result<T: serde::Serialize>(
        &mut self,
        path: &Path,
        format: parallax_interop::Format,
        native: &T,
        calibration: Option<&parallax_interop::Calibration>,
    ) -> Result<Vec<PathBuf>> {
        use parallax_interop::Format;
        let files = match (format, calibration) {
            (Format::Ron | Format::Json, _) => {
                vec![(path.to_path_buf(), parallax_interop::native_string(native, format)?)]
            }
            (_, Some(c)) => parallax_interop::render(c, format, path)?,
            (_, None) => {
                return Err(PipelineError::Input(format!(
                    "{}: this result is written as ron or json, not {}",
                    path.display(),
                    format.name()
                )));
            }
        };
        let paths = files.iter().map(|f| f.0.clone()).collect();
        for (p, text) in files {
            self.add(p, text)?;
        }
        Ok(paths)
    }

    /// The bytes staged for `path`, if any.
    pub fn get(&self, path: &Path) -> Option<Vec<u8>> {
        let (_, tmp) = self.files.iter().find(|(p, _)| p == path)?;
        std::fs::read(tmp).ok()
    }

    /// The paths in the order they were added.
    pub fn paths(&self) -> Vec<&Path> {
        self.files.iter().map(|(p, _)| p.as_path()).collect()
    }

    /// Number of files.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether the set has no file.
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// Marks `path` as a file of this run's kind that an earlier run may have left: when the set
    /// does not write it, the commit removes it, so an output folder never holds a new map beside
    /// an older run's depth cloud. Give only names the command checked against its inputs.
    pub fn supersede(&mut self, path: impl Into<PathBuf>) {
        self.superseded.push(path.into());
    }

    /// Renames every staged file into place, then removes the superseded files it did not write;
    /// returns the paths written.
    pub fn commit(mut self) -> Result<Vec<PathBuf>> {
        let journal = self.write_journal(std::process::id())?;
        let result = self.rename_all();
        if let Some(j) = journal {
            let _ = std::fs::remove_file(j);
        }
        result
    }

    /// Writes the commit's journal (see [`finish_killed_commits`]) beside the first file, synced
    /// to disk before any rename; `None` for a set of one file and nothing to remove (a single
    /// rename is atomic by itself).
    fn write_journal(&self, pid: u32) -> Result<Option<PathBuf>> {
        let Some((first, _)) = self.files.first() else { return Ok(None) };
        if self.files.len() == 1 && self.superseded.is_empty() {
            return Ok(None);
        }
        let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        let mut text = String::new();
        for (path, tmp) in &self.files {
            text.push_str(&format!("rename\t{}\t{}\n", abs(tmp).display(), abs(path).display()));
        }
        for stale in self.superseded.iter().filter(|s| self.files.iter().all(|(p, _)| p != *s)) {
            text.push_str(&format!("remove\t{}\n", abs(stale).display()));
        }
        text.push_str("end\n");
        let dir = first.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let journal = dir.join(format!("{JOURNAL_PREFIX}{pid}"));
        let write = || -> std::io::Result<()> {
            use std::io::Write;
            let mut f = std::fs::File::create(&journal)?;
            f.write_all(text.as_bytes())?;
            f.sync_all()
        };
        write().map_err(io_err("writing the commit journal", &journal))?;
        Ok(Some(journal))
    }

    /// The renames and removals of [`Self::commit`].
    fn rename_all(&mut self) -> Result<Vec<PathBuf>> {
        for k in 0..self.files.len() {
            let (path, tmp) = &self.files[k];
            if let Err(source) = std::fs::rename(tmp, path) {
                let err = PipelineError::Io { what: "renaming a temporary file to", path: path.clone(), source };
                let done: Vec<String> = self.files.drain(..k).map(|(p, _)| p.display().to_string()).collect();
                if !done.is_empty() {
                    self.created.clear(); // they hold files now
                    return Err(PipelineError::Input(format!("{err}; already in place: {}", done.join(", "))));
                }
                return Err(err);
            }
        }
        self.committed = true;
        for stale in &self.superseded {
            if self.files.iter().all(|(p, _)| p != stale) && stale.is_file() {
                std::fs::remove_file(stale).map_err(|source| PipelineError::Io {
                    what: "removing the earlier run's",
                    path: stale.clone(),
                    source,
                })?;
            }
        }
        Ok(std::mem::take(&mut self.files).into_iter().map(|(p, _)| p).collect())
    }
}

/// The name of a commit journal: `.parallax-commit-{pid}`.
const JOURNAL_PREFIX: &str = ".parallax-commit-";

/// Finishes the commits that runs killed half-way (`kill -9`, a power cut) left in `dir`: an
/// [`OutputSet`] writes, before its first rename, a journal of every rename and removal it will
/// make (`.parallax-commit-{pid}`, synced to disk); a journal whose process is gone is replayed —
/// the staged files still there are renamed into place, the earlier run's files removed — so the
/// folder holds the new set, never a mix of two runs. A journal cut short (killed while writing
/// it, before any rename) is dropped: the old set is still whole. Every set that stages into a
/// folder calls this first; a program reading outputs that a killed run may have left can call
/// it too. Runs only where `/proc` tells the living processes (Linux), like the cleanup of
/// staged files.
pub fn finish_killed_commits(dir: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(pid) = file.to_str().and_then(|f| f.strip_prefix(JOURNAL_PREFIX)).and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists() {
            continue;
        }
        let text = std::fs::read_to_string(e.path()).unwrap_or_default();
        if text.ends_with("end\n") {
            for line in text.lines() {
                let parts: Vec<&str> = line.split('\t').collect();
                match parts[..] {
                    ["rename", tmp, path] if Path::new(tmp).is_file() => {
                        let _ = std::fs::rename(tmp, path);
                    }
                    ["remove", stale] if Path::new(stale).is_file() => {
                        let _ = std::fs::remove_file(stale);
                    }
                    _ => {}
                }
            }
        }
        let _ = std::fs::remove_file(e.path());
    }
}

/// Removes the temporary files that runs killed while staging left in `dir`
/// (`.{name}.tmp{pid}-{k}` whose process no longer exists), whatever output they were for:
/// `kill -9` skips the cleanup of [`OutputSet`]'s `Drop`, and the next run need not write the
/// same outputs (a run with `--confidence` killed, then one without). A process is known to be
/// gone only where `/proc` lists the living ones (Linux); elsewhere nothing is removed, since
/// the file may be another live run's.
fn remove_dead_runs_temps(dir: &Path) {
    let proc_fs = Path::new("/proc/self");
    if !proc_fs.exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix('.')).and_then(|f| f.rsplit_once(".tmp")) else {
            continue;
        };
        let Some((pid, k)) = rest.1.split_once('-') else { continue };
        let (Ok(pid), Ok(_)) = (pid.parse::<u32>(), k.parse::<usize>()) else { continue };
        if !rest.0.is_empty() && pid != std::process::id() && !Path::new("/proc").join(pid.to_string()).exists() {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

impl Drop for OutputSet {
    /// Without a commit: the staged files and the folders made for them go.
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        for (_, tmp) in &self.files {
            let _ = std::fs::remove_file(tmp);
        }
        for d in self.created.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
    }
}

/// Refuses a run whose output would replace one of its inputs (`measure --calib c.ron --out
/// c.ron`): each output path is compared with each input path, both canonicalised (symbolic
/// links, `..` and relative paths resolved; an output that does not exist yet is its longest
/// existing ancestor canonicalised plus the rest resolved lexically, see [`resolved_output`]).
/// Inputs that do not exist are skipped (they are
/// reported by the reader). An output that is an existing directory is refused too. Call it
/// before any work, with every file the command may write.
pub fn refuse_overwriting_inputs<O: AsRef<Path>, I: AsRef<Path>>(outputs: &[O], inputs: &[I]) -> Result<()> {
    let inputs: Vec<(PathBuf, &Path)> =
        inputs.iter().filter_map(|i| Some((i.as_ref().canonicalize().ok()?, i.as_ref()))).collect();
    for out in outputs {
        let out = out.as_ref();
        if out.is_dir() {
            return Err(PipelineError::Input(format!(
                "{} is a directory: give a file name (e.g. {})",
                out.display(),
                out.join("result.ron").display()
            )));
        }
        let Some(o) = resolved_output(out) else { continue };
        if let Some((_, input)) = inputs.iter().find(|(c, _)| *c == o) {
            return Err(PipelineError::Input(format!(
                "{} is also an input ({}): refusing to write a result over an input; choose another output path",
                out.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// Refuses two outputs of one command that resolve to the same file, and a file output inside a
/// folder another output writes (`(flag, path, is_folder)`): the second write would replace the
/// first (`handeye --out X --save-camera-poses X`, `calibrate --out R/report.html --report R`).
/// Call it before any work, with the command's flags as given.
pub fn refuse_colliding_outputs(outputs: &[(&str, &Path, bool)]) -> Result<()> {
    let resolved: Vec<(&str, &Path, bool, PathBuf)> =
        outputs.iter().filter_map(|&(flag, p, dir)| Some((flag, p, dir, resolved_output(p)?))).collect();
    for (i, (flag_a, a, dir_a, ra)) in resolved.iter().enumerate() {
        for (flag_b, b, dir_b, rb) in &resolved[i + 1..] {
            let clash =
                ra == rb || (*dir_a && !*dir_b && rb.starts_with(ra)) || (*dir_b && !*dir_a && ra.starts_with(rb));
            if clash {
                return Err(PipelineError::Input(format!(
                    "{flag_a} {} and {flag_b} {} are the same place: one would replace the other; give each \
                     output its own path",
                    a.display(),
                    b.display()
                )));
            }
        }
    }
    Ok(())
}

/// The absolute path a file written at `p` will have: its longest existing ancestor
/// canonicalised (links resolved), then the rest of its components resolved lexically — exact,
/// since below a folder that does not exist yet nothing is a link (`new/../c.ron` is `c.ron`:
/// compared by its parent alone, a missing `new/..` skipped the check and the write then
/// replaced `c.ron`). `None` only when no ancestor resolves (no working directory).
fn resolved_output(p: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let abs = if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir().ok()?.join(p) };
    let parts: Vec<Component> = abs.components().collect();
    let (k, mut out) =
        (1..=parts.len()).rev().find_map(|k| Some((k, parts[..k].iter().collect::<PathBuf>().canonicalize().ok()?)))?;
    for c in &parts[k..] {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::Normal(n) => out.push(n),
            // a root or prefix cannot follow the first component
            Component::CurDir | Component::RootDir | Component::Prefix(_) => {}
        }
    }
    Some(out)
}

/// The files an input argument names, for [`refuse_overwriting_inputs`]: the path itself and,
/// when it is a glob pattern, every file it matches (a malformed pattern gives the path alone).
pub fn input_paths(spec: &str) -> Vec<PathBuf> {
    let mut out = vec![PathBuf::from(spec)];
    if let Ok(paths) = glob::glob(spec) {
        out.extend(paths.filter_map(std::result::Result::ok));
    }
    out
}

/// Serialises `value` as pretty RON.
pub fn to_ron<T: serde::Serialize>(value: &T) -> Result<String> {
    ron::ser::to_string_pretty(value, ron::ser::PrettyConfig::default())
        .map_err(|e| PipelineError::Format { path: PathBuf::from("<value>"), message: e.to_string() })
}

/// Serialises `value` as pretty RON and writes it atomically.
pub fn write_ron<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    write_atomic(path, to_ron(value)?.as_bytes())
}

/// Reads and deserialises a RON file, naming the file in every error.
pub fn read_ron<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = parallax_interop::read_text_file(path).map_err(io_err("reading", path))?;
    parallax_interop::check_nesting(&text, &path.display().to_string())?;
    ron::from_str(&text).map_err(|e| PipelineError::Format { path: path.to_path_buf(), message: e.to_string() })
}

/// Writes a result as a set of files ([`OutputSet`]): `native` as RON or JSON, or
/// `calibration` in a calibration format (OpenCV, ROS, Kalibr; some write two files); a result
/// that is no calibration is refused in those. Returns the files written.
pub fn write_result<T: serde::Serialize>(
    path: &Path,
    format: parallax_interop::Format,
    native: &T,
    calibration: Option<&parallax_interop::Calibration>,
) -> Result<Vec<PathBuf>> {
    let mut set = OutputSet::new();
    set.add_result(path, format, native, calibration)?;
    set.commit()
}

/// A fresh, empty directory under the system temp dir for a test (`name` and the process id).
#[cfg(test)]
pub(crate) fn test_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("parallax-composition-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("creating a test directory");
    d
}

/// Largest image accepted by [`load_image`]: 2^28 pixels (e.g. 16384 x 16384), and at most
/// 2 GiB of decoded data, so a corrupt or hostile header cannot make the decoder allocate more.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 28;

/// Largest allocation the image decoder may make in [`load_image`]: 2 GiB.
pub const MAX_IMAGE_BYTES: u64 = 2 << 30;

/// Decodes an image file, refusing what a decoder would silently accept: a JPEG without its
/// end-of-image marker (a truncated file decodes with the missing rows grey), images larger
/// than [`MAX_IMAGE_PIXELS`], and anything the decoder reports. Every error names the file.
pub fn load_image(path: &Path) -> Result<image::DynamicImage> {
    // a file larger than the largest decoded image is refused before it is read
    let bytes = parallax_interop::read_bounded(path, MAX_IMAGE_BYTES).map_err(io_err("reading", path))?;
    decode_image(&bytes, path)
}

/// [`load_image`] on bytes already in memory; `path` names them in errors.
pub fn decode_image(bytes: &[u8], path: &Path) -> Result<image::DynamicImage> {
    let image_err = |source| PipelineError::Image { path: path.to_path_buf(), source };
    let format = image::guess_format(bytes).map_err(image_err)?;
    if format == image::ImageFormat::Jpeg {
        // A complete JPEG ends with the EOI marker FF D9 (some writers pad with zeros after it).
        let end = bytes.iter().rposition(|&b| b != 0).map_or(0, |i| i + 1);
        if end < 2 || bytes[end - 2..end] != [0xFF, 0xD9] {
            return Err(PipelineError::Input(format!(
                "{}: truncated or corrupt JPEG (no end-of-image marker): re-export or re-copy the file",
                path.display()
            )));
        }
        // a file cut short with an end marker after it: the decoder would fill the rest with grey
        if let Err(e) = crate::jpeg_scan::check(bytes) {
            return Err(PipelineError::Input(format!(
                "{}: truncated or corrupt JPEG: {e}: re-export or re-copy the file",
                path.display()
            )));
        }
    }
    let reader = || {
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(MAX_IMAGE_BYTES);
        reader.limits(limits);
        reader
    };
    let (w, h) = reader().into_dimensions().map_err(image_err)?;
    if u64::from(w) * u64::from(h) > MAX_IMAGE_PIXELS {
        return Err(PipelineError::Input(format!(
            "{}: {w}x{h} is larger than the {MAX_IMAGE_PIXELS}-pixel limit",
            path.display()
        )));
    }
    reader().decode().map_err(image_err)
}

/// Loads an image as 8-bit grayscale (colour is converted with the image crate's luma weights),
/// through [`load_image`]'s checks.
pub fn load_gray(path: &Path) -> Result<image::GrayImage> {
    Ok(load_image(path)?.into_luma8())
}

/// Encodes an image as PNG (in memory).
pub fn png_bytes<P, C>(img: &image::ImageBuffer<P, C>) -> Result<Vec<u8>>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|source| PipelineError::Image { path: PathBuf::from("<png>"), source })?;
    Ok(bytes)
}

/// Encodes an image as PNG and writes it atomically.
pub fn save_png<P, C>(path: &Path, img: &image::ImageBuffer<P, C>) -> Result<()>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    write_atomic(path, &png_bytes(img)?)
}

/// Orders paths by the numbers in their names (`img2` before `img10`), then by text.
pub fn natural_sort(paths: &mut [PathBuf]) {
    fn key(p: &Path) -> Vec<(String, u64)> {
        let s = p.to_string_lossy();
        let mut out = Vec::new();
        let (mut text, mut num) = (String::new(), None::<u64>);
        for c in s.chars() {
            match (c.to_digit(10), num) {
                (Some(d), Some(n)) => num = Some(n.saturating_mul(10).saturating_add(u64::from(d))),
                (Some(d), None) => num = Some(u64::from(d)),
                (None, Some(n)) => {
                    out.push((std::mem::take(&mut text), n));
                    num = None;
                    text.push(c);
                }
                (None, None) => text.push(c),
            }
        }
        out.push((text, num.unwrap_or(0)));
        out
    }
    paths.sort_by_cached_key(|p| key(p));
}

/// Expands a glob pattern into paths in natural order (numbers in names compare as numbers);
/// errors when the pattern is malformed or nothing matches.
pub fn expand_glob(pattern: &str) -> Result<Vec<PathBuf>> {
    let paths = glob::glob(pattern).map_err(|e| PipelineError::Input(format!("bad glob pattern {pattern:?}: {e}")))?;
    let mut paths: Vec<PathBuf> = paths.filter_map(std::result::Result::ok).collect();
    natural_sort(&mut paths);
    if paths.is_empty() {
        return Err(PipelineError::Input(format!("no file matches {pattern:?}")));
    }
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_killed_runs_temporary_files_are_removed_by_the_next_run() {
        // `kill -9` during the staging left `.name.tmpPID-K` files that nothing removed (issue 51)
        if !Path::new("/proc/self").exists() {
            println!("skipped: no /proc here to tell a dead run from a live one");
            return;
        }
        let dir = test_dir("dead-temps");
        let pid_max: u64 = std::fs::read_to_string("/proc/sys/kernel/pid_max")
            .ok()
            .and_then(|s| s.trim().parse().ok())
            .unwrap_or(4_194_304);
        // a pid above pid_max never belongs to a process
        let dead = dir.join(format!(".c.ron.tmp{}-0", pid_max + 1));
        let live = dir.join(format!(".c.ron.tmp{}-3", 1)); // pid 1 is always alive
        // another output's, which this run does not write (a killed `--confidence` run's)
        let other = dir.join(format!(".d.ron.tmp{}-0", pid_max + 1));
        let unrelated = dir.join(".notes.txt"); // no run's temporary
        for f in [&dead, &live, &other, &unrelated] {
            std::fs::write(f, b"half").unwrap();
        }
        let mut set = OutputSet::new();
        set.add(dir.join("c.ron"), b"new").unwrap();
        set.commit().unwrap();
        assert!(!dead.exists() && !other.exists(), "a dead run's temporary is left");
        assert!(live.exists() && unrelated.exists(), "a live run's temporary or another file was removed");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_larger_than_any_image_is_refused_unread() {
        // a 2 GB file named .png was read whole before it was refused (issue 51); sparse here
        let dir = test_dir("huge-image");
        let path = dir.join("huge.png");
        std::fs::File::create(&path).unwrap().set_len(MAX_IMAGE_BYTES + 1).unwrap();
        let err = load_image(&path).unwrap_err().to_string();
        assert!(err.contains("huge.png") && err.contains("more than the 2147483648 bytes"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp_file() {
        let dir = test_dir("io-atomic");
        let path = dir.join("a.ron");
        write_ron(&path, &vec![1, 2, 3]).unwrap();
        write_ron(&path, &vec![4]).unwrap();
        let back: Vec<i32> = read_ron(&path).unwrap();
        assert_eq!(back, vec![4]);
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1, "temporary files left behind: {names:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_directory_as_output_file_is_refused_and_leaves_nothing() {
        let dir = test_dir("io-isdir");
        std::fs::create_dir_all(dir.join("out.ron")).unwrap();
        let err = write_atomic(&dir.join("out.ron"), b"x").unwrap_err().to_string();
        assert!(err.contains("is a directory"), "{err}");
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1, "{names:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The files under `dir` (folders walked), relative, sorted.
    fn listing(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            walk(dir).iter().map(|p| p.strip_prefix(dir).unwrap().display().to_string()).collect();
        names.sort();
        names
    }

    fn walk(dir: &Path) -> Vec<PathBuf> {
        let mut out = Vec::new();
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                out.extend(walk(&p));
            } else {
                out.push(p);
            }
        }
        out
    }

    #[test]
    fn a_set_is_written_whole_or_not_at_all() {
        let dir = test_dir("io-set");
        std::fs::write(dir.join("old.txt"), b"before").unwrap();
        // a run that fails after staging (here: a destination whose parent is a file): nothing
        // of the set appears, the existing file is unchanged, no temporary file or folder is left
        {
            let mut set = OutputSet::new();
            set.add(dir.join("a.txt"), b"a").unwrap();
            set.add(dir.join("old.txt"), b"after").unwrap();
            set.add(dir.join("sub/deeper/b.txt"), b"b").unwrap();
            assert!(set.add(dir.join("old.txt/c.txt"), b"c").is_err());
            assert_eq!(set.len(), 3);
            // the staged files are hidden beside their destinations until the commit
            assert!(listing(&dir).iter().any(|n| n.starts_with(".a.txt.tmp")), "{:?}", listing(&dir));
        }
        assert_eq!(listing(&dir), ["old.txt"]);
        assert!(!dir.join("sub").exists(), "a folder made for the set stayed behind");
        assert_eq!(std::fs::read(dir.join("old.txt")).unwrap(), b"before");
        // a directory as a destination is refused when added
        std::fs::create_dir_all(dir.join("d.ron")).unwrap();
        let mut set = OutputSet::new();
        set.add(dir.join("a.txt"), b"a").unwrap();
        let err = set.add(dir.join("d.ron"), b"d").unwrap_err().to_string();
        assert!(err.contains("d.ron is a directory"), "{err}");
        drop(set);
        assert!(!dir.join("a.txt").exists());
        std::fs::remove_dir(dir.join("d.ron")).unwrap();
        // the whole set when every file can be written (a path added twice keeps the last bytes)
        let mut set = OutputSet::new();
        set.add(dir.join("a.txt"), b"first").unwrap();
        set.add(dir.join("old.txt"), b"after").unwrap();
        set.add(dir.join("sub/b.txt"), b"b").unwrap();
        set.add(dir.join("a.txt"), b"a").unwrap();
        assert_eq!(set.get(&dir.join("sub/b.txt")).as_deref(), Some(&b"b"[..]));
        let written = set.commit().unwrap();
        assert_eq!(written.len(), 3);
        assert_eq!(listing(&dir), ["a.txt", "old.txt", "sub/b.txt"]);
        assert_eq!(std::fs::read(dir.join("old.txt")).unwrap(), b"after");
        assert_eq!(std::fs::read(dir.join("a.txt")).unwrap(), b"a");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unreadable_inputs_name_the_file() {
        let err = read_ron::<Vec<i32>>(Path::new("/nonexistent/x.ron")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/x.ron"), "{err}");
        let err = load_gray(Path::new("/nonexistent/x.png")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/x.png"), "{err}");
        assert!(expand_glob("/nonexistent/*.png").is_err());
    }

    /// A commit killed after some of its renames (simulated: the journal of a process that no
    /// longer exists, half the files renamed, the superseded file still there) is finished by the
    /// next set that stages into the folder: the new set whole, the earlier run's extra file
    /// gone, no journal or staged file left. A journal cut short is dropped and the old set kept.
    #[test]
    fn a_commit_killed_half_way_is_finished_by_the_next_run() {
        let dir = test_dir("io-journal");
        std::fs::create_dir_all(&dir).unwrap();
        for (name, text) in [("a.txt", "old a"), ("b.txt", "old b"), ("c.txt", "old c"), ("stale.txt", "old")] {
            std::fs::write(dir.join(name), text).unwrap();
        }
        let mut set = OutputSet::new();
        for name in ["a.txt", "b.txt", "c.txt"] {
            set.add(dir.join(name), format!("new {}", &name[..1])).unwrap();
        }
        set.supersede(dir.join("stale.txt"));
        // a dead process: above any pid the kernel hands out (pid_max ≤ 2^22)
        let dead = 1 << 23;
        let journal = set.write_journal(dead).unwrap().unwrap();
        std::fs::rename(&set.files[0].1, &set.files[0].0).unwrap();
        std::mem::forget(set); // killed: no cleanup
        let read = |n: &str| std::fs::read_to_string(dir.join(n)).ok();
        assert_eq!((read("a.txt"), read("b.txt")), (Some("new a".into()), Some("old b".into())), "a mix, for now");
        // the next run's set stages into the folder
        let mut next = OutputSet::new();
        next.add(dir.join("other.txt"), "x").unwrap();
        drop(next);
        assert!(!journal.exists());
        assert_eq!(
            [read("a.txt"), read("b.txt"), read("c.txt")],
            [Some("new a".into()), Some("new b".into()), Some("new c".into())]
        );
        assert_eq!(read("stale.txt"), None);
        let left: Vec<String> =
            std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        assert!(left.iter().all(|n| !n.starts_with('.')), "{left:?}");
        // a journal cut short (no `end`): dropped, the files stay as they are
        std::fs::write(
            dir.join(format!("{JOURNAL_PREFIX}{dead}")),
            format!("rename\t{}\t{}\n", dir.join(".x").display(), dir.join("a.txt").display()),
        )
        .unwrap();
        finish_killed_commits(&dir);
        assert_eq!(read("a.txt"), Some("new a".into()));
        assert!(!dir.join(format!("{JOURNAL_PREFIX}{dead}")).exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_truncated_jpeg_is_refused_naming_the_file() {
        let dir = test_dir("io-jpeg");
        std::fs::create_dir_all(&dir).unwrap();
        let img = image::GrayImage::from_fn(64, 48, |x, y| image::Luma([((x * 7 + y * 3) % 256) as u8]));
        let mut bytes = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Jpeg).unwrap();
        let whole = dir.join("whole.jpg");
        std::fs::write(&whole, &bytes).unwrap();
        assert_eq!(load_gray(&whole).unwrap().dimensions(), (64, 48));
        let cut = dir.join("cut.jpg");
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
        let err = load_gray(&cut).unwrap_err().to_string();
        assert!(err.contains("cut.jpg") && err.contains("truncated"), "{err}");
        let garbage = dir.join("garbage.png");
        std::fs::write(&garbage, b"\x89PNG\r\n\x1a\nnot really").unwrap();
        assert!(load_gray(&garbage).unwrap_err().to_string().contains("garbage.png"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn results_are_written_in_their_format_and_a_non_calibration_is_refused_elsewhere() {
        use parallax_interop::Format;
        let dir = test_dir("io-result");
        let written = write_result(&dir.join("r.json"), Format::Json, &vec![1.5, 2.0], None).unwrap();
        assert_eq!(written, [dir.join("r.json")]);
        let back: Vec<f64> = serde_json_free_parse(&std::fs::read_to_string(&written[0]).unwrap());
        assert_eq!(back, [1.5, 2.0]);
        let err = write_result(&dir.join("r.yml"), Format::OpenCvYaml, &vec![1.0], None).unwrap_err().to_string();
        assert!(err.contains("written as ron or json, not opencv"), "{err}");
        assert!(!dir.join("r.yml").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A JSON list of numbers, read without a JSON dependency (RON reads this subset).
    fn serde_json_free_parse(text: &str) -> Vec<f64> {
        ron::from_str(text).unwrap()
    }

    #[test]
    fn an_output_onto_an_input_is_refused_through_any_spelling_of_the_path() {
        let dir = test_dir("overwrite");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let calib = dir.join("c.ron");
        std::fs::write(&calib, b"()").unwrap();
        // The same file through `..`, and a new file beside it.
        let spelled = dir.join("sub").join("..").join("c.ron");
        let err = refuse_overwriting_inputs(&[&spelled], &[&calib]).unwrap_err().to_string();
        assert!(err.contains("is also an input") && err.contains("c.ron"), "{err}");
        refuse_overwriting_inputs(&[dir.join("m.ron")], &[&calib]).unwrap();
        let err = refuse_overwriting_inputs(&[dir.join("sub")], &[&calib]).unwrap_err().to_string();
        assert!(err.contains("is a directory"), "{err}");
        // An output that does not exist yet cannot be an input; a missing input is skipped.
        refuse_overwriting_inputs(&[dir.join("new").join("m.ron")], &[dir.join("missing.ron")]).unwrap();
        // ... unless its path comes back through folders that do not exist yet (`new/..`, and
        // deeper), which the write would create: it used to pass, and the write replaced c.ron
        for spelled in [dir.join("new/../c.ron"), dir.join("new/deeper/../../c.ron"), dir.join("new/./../sub/../c.ron")]
        {
            let err = refuse_overwriting_inputs(&[&spelled], &[&calib]).unwrap_err().to_string();
            assert!(err.contains("is also an input"), "{}: {err}", spelled.display());
        }
        refuse_overwriting_inputs(&[dir.join("new/../m.ron"), dir.join("new/deeper/../c.ron")], &[&calib]).unwrap();
        // relative to the working directory: up to the root, then down to c.ron
        #[cfg(unix)]
        {
            let up = std::env::current_dir().unwrap().components().count() - 1;
            let rel = Path::new("nowhere/..").join("../".repeat(up)).join(calib.strip_prefix("/").unwrap());
            assert!(refuse_overwriting_inputs(&[&rel], &[&calib]).is_err(), "{}", rel.display());
        }
        // Globs name every file they match.
        let pattern = format!("{}/*.ron", dir.display());
        let matched = input_paths(&pattern);
        assert!(matched.contains(&calib), "{matched:?}");
        assert!(refuse_overwriting_inputs(&[&calib], &matched).is_err());
        #[cfg(unix)]
        {
            let link = dir.join("link.ron");
            std::os::unix::fs::symlink(&calib, &link).unwrap();
            assert!(refuse_overwriting_inputs(&[&link], &[&calib]).is_err());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn natural_sort_orders_numbers_numerically() {
        let mut p: Vec<PathBuf> =
            ["img10.png", "img2.png", "img1.png", "a/img03.png"].iter().map(PathBuf::from).collect();
        natural_sort(&mut p);
        let names: Vec<_> = p.iter().map(|p| p.to_string_lossy().into_owned()).collect();
        assert_eq!(names, ["a/img03.png", "img1.png", "img2.png", "img10.png"]);
    }
}
