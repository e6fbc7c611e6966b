//! Scene files name meshes by relative path. A scene may come from an
//! untrusted upload, so a reference must stay inside the scene's directory:
//! no absolute paths, no `..`, no symlink leading out.

use std::path::{Component, Path, PathBuf};

use crate::{Error, Result};

/// Resolves `file` against `base` and checks that the result lies inside
/// `base`.
pub fn resolve_relative(base: Option<&Path>, file: &str) -> Result<PathBuf> {
    let fail = |reason: &str| Error::InvalidPath {
        path: file.to_owned(),
        reason: reason.to_owned(),
    };
    let base = base.ok_or_else(|| {
        fail("a scene given as text has no directory to resolve files against; load it from a file")
    })?;
    let rel = Path::new(file);
    if file.is_empty() || file.contains('\0') {
        return Err(fail("empty or invalid file name"));
    }
    if !rel
        .components()
        .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(fail(
            "file paths must be relative to the scene's directory, without `..`",
        ));
    }
    let joined = base.join(rel);
    let io = |path: &Path, e: std::io::Error| Error::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    };
    let real = joined.canonicalize().map_err(|e| io(&joined, e))?;
    let real_base = base.canonicalize().map_err(|e| io(base, e))?;
    if !real.starts_with(&real_base) {
        return Err(fail(
            "the file resolves (through a link) outside the scene's directory",
        ));
    }
    Ok(real)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::test_dir;

    #[test]
    fn stays_inside_the_base_directory() {
        let dir = test_dir("paths");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(dir.join("sub/a.obj"), "").unwrap();
        assert!(resolve_relative(Some(&dir), "sub/a.obj").is_ok());
        assert!(resolve_relative(Some(&dir), "./sub/a.obj").is_ok());
        for bad in [
            "../x.obj",
            "sub/../../x.obj",
            "/etc/passwd",
            "",
            "missing.obj",
        ] {
            assert!(resolve_relative(Some(&dir), bad).is_err(), "{bad}");
        }
        assert!(resolve_relative(None, "sub/a.obj").is_err());
        let _ = std::fs::remove_dir_all(dir);
    }
}
