//! The point motion keys of a mesh collider (`sequence`, `cache`, `frame_rate`, `start`): which
//! may be given together, and the frames they name, read and checked against the rest mesh.

use crate::error::SceneError;
use crate::obj::ObjMesh;
use crate::raw::{Ctx, mesh_path};
use std::ops::Range;
use std::sync::Arc;
use toml::Spanned;
use wetcloth::Real;
use wetcloth::collide::{PointMotion, PointSource};

/// The motion keys as written.
pub(crate) struct Keys<'a> {
    pub sequence: Option<&'a Spanned<String>>,
    pub cache: Option<&'a Spanned<String>>,
    pub frame_rate: Option<&'a Spanned<Real>>,
    pub start: Option<&'a Spanned<Real>>,
}

/// What the keys give: the motion (with the span and name of the key that names its files, for
/// errors found later), and for a sequence without `file` its pattern and first frame's mesh
/// (the rest mesh).
pub(crate) struct Read {
    pub motion: Option<(PointMotion, Range<usize>, &'static str)>,
    pub rest: Option<(Spanned<String>, ObjMesh)>,
}

/// Reads the motion of the mesh collider whose keys are named by `key`, its table at `table`,
/// with rest mesh `rest` (its `file`, when given).
pub(crate) fn read(
    cx: &Ctx<'_>,
    key: &dyn Fn(&str) -> String,
    table: Range<usize>,
    rest: Option<&ObjMesh>,
    k: Keys<'_>,
) -> Result<Read, SceneError> {
    let invalid = |name: &str, span: Range<usize>, message: String| SceneError::Invalid {
        at: cx.at(span.clone()),
        key: key(name),
        value: cx.raw(&span),
        message,
    };
    let named = match (k.sequence, k.cache) {
        (Some(_), Some(c)) => {
            return Err(invalid(
                "cache",
                c.span(),
                "give either `sequence` (an OBJ file per frame) or `cache` (a PC2 or MDD point \
                 cache), not both"
                    .into(),
            ));
        }
        (Some(s), None) => Some((s, "sequence")),
        (None, Some(c)) => Some((c, "cache")),
        (None, None) => None,
    };
    let Some((file, which)) = named else {
        for (name, span) in [
            ("frame_rate", k.frame_rate.map(|s| s.span())),
            ("start", k.start.map(|s| s.span())),
        ] {
            if let Some(span) = span {
                return Err(invalid(
                    name,
                    span,
                    format!(
                        "`{name}` times a mesh's point motion: it needs `sequence = \
                         \"body/frame_####.obj\"` or `cache = \"body.pc2\"`"
                    ),
                ));
            }
        }
        return Ok(Read {
            motion: None,
            rest: None,
        });
    };
    let frame_rate = k.frame_rate.ok_or_else(|| SceneError::Missing {
        at: cx.at(table.clone()),
        key: key("frame_rate"),
        message: format!(
            "a mesh collider with `{which}` needs frame_rate = ... (1/s, the {which}'s own \
             frames per second)"
        ),
    })?;
    let path = mesh_path(cx, file.get_ref());
    let absolute = std::path::absolute(&path).unwrap_or(path.clone());
    let fail = |message: String| invalid(which, file.span(), message);
    let (frames, source, first) = if which == "sequence" {
        let (frames, first, first_path) =
            crate::points::read_sequence(&path, rest).map_err(fail)?;
        let first_path = std::path::absolute(&first_path).unwrap_or(first_path);
        (
            frames,
            PointSource::Sequence(absolute.display().to_string()),
            Some((first, first_path.display().to_string())),
        )
    } else {
        let Some(rest) = rest else {
            return Err(SceneError::Missing {
                at: cx.at(table),
                key: key("file"),
                message: "a point cache moves a rest mesh: it needs file = \"body.obj\" (the \
                          mesh the cache applies to, vertex for vertex)"
                    .into(),
            });
        };
        let frames = crate::points::read_cache(&path, rest.vertices.len()).map_err(fail)?;
        (
            frames,
            PointSource::Cache(absolute.display().to_string()),
            None,
        )
    };
    let motion = PointMotion {
        source,
        frame_rate: *frame_rate.get_ref(),
        start: k.start.map_or(0.0, |s| *s.get_ref()),
        frames: Arc::new(frames),
    };
    Ok(Read {
        motion: Some((motion, file.span(), which)),
        rest: match (rest, first) {
            // The rest mesh is frame 0's file, named by its path (so the resolved scene reads
            // it back as `file`), at the `sequence` key for errors.
            (None, Some((first, path))) => Some((Spanned::new(file.span(), path), first)),
            _ => None,
        },
    })
}
