//! Reader for the continuous-collision benchmark of Wang et al. 2021 (the
//! "Sample-Queries" collection): per folder, `edge-edge/*.csv` and
//! `vertex-face/*.csv`, eight rows per query (the primitives' points at
//! t = 0, then at t = 1), each row `x_num, x_den, y_num, y_den, z_num,
//! z_den, truth`. Coordinates are rationals that must convert to f64
//! exactly; one that does not is an error, not a rounded query.

use std::path::Path;

use glam::DVec3;

use super::inclusion::{CcdOptions, CcdScratch, EdgeEdge, VertexFace};
use crate::{Error, Result};

/// One query with its exact answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampleQuery {
    VertexFace { query: VertexFace, collides: bool },
    EdgeEdge { query: EdgeEdge, collides: bool },
}

impl SampleQuery {
    /// Whether the primitives touch, by the ground truth.
    pub fn collides(&self) -> bool {
        match self {
            SampleQuery::VertexFace { collides, .. } | SampleQuery::EdgeEdge { collides, .. } => {
                *collides
            }
        }
    }

    /// The test's answer: earliest time of impact, or `None`.
    pub fn time_of_impact(&self, options: &CcdOptions, scratch: &mut CcdScratch) -> Option<f64> {
        match self {
            SampleQuery::VertexFace { query, .. } => query.time_of_impact(options, scratch),
            SampleQuery::EdgeEdge { query, .. } => query.time_of_impact(options, scratch),
        }
    }
}

/// Every query under `root`, per folder (sorted by name), each folder's
/// files in name order.
pub fn read_sample_queries(root: &Path) -> Result<Vec<(String, Vec<SampleQuery>)>> {
    let mut folders = Vec::new();
    for dir in sorted_entries(root)? {
        if !dir.is_dir() {
            continue;
        }
        let name = dir
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let mut queries = Vec::new();
        for (kind, vertex_face) in [("edge-edge", false), ("vertex-face", true)] {
            let sub = dir.join(kind);
            if !sub.is_dir() {
                continue;
            }
            for file in sorted_entries(&sub)? {
                if file.extension().is_some_and(|e| e == "csv") {
                    read_file(&file, vertex_face, &mut queries)?;
                }
            }
        }
        folders.push((name, queries));
    }
    Ok(folders)
}

fn io_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

fn sorted_entries(dir: &Path) -> Result<Vec<std::path::PathBuf>> {
    let mut paths = std::fs::read_dir(dir)
        .map_err(|e| io_error(dir, e))?
        .map(|e| e.map(|e| e.path()))
        .collect::<std::io::Result<Vec<_>>>()
        .map_err(|e| io_error(dir, e))?;
    paths.sort();
    Ok(paths)
}

fn read_file(path: &Path, vertex_face: bool, out: &mut Vec<SampleQuery>) -> Result<()> {
    let text = std::fs::read_to_string(path).map_err(|e| io_error(path, e))?;
    let parse_error = |line: usize, reason: String| Error::Parse {
        what: format!("{}:{}", path.display(), line + 1),
        reason,
    };
    let rows: Vec<(DVec3, bool)> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| parse_row(l).map_err(|r| parse_error(i, r)))
        .collect::<Result<_>>()?;
    if rows.len() % 8 != 0 {
        return Err(parse_error(
            rows.len(),
            format!("{} rows is not a whole number of 8-row queries", rows.len()),
        ));
    }
    for (q, chunk) in rows.chunks_exact(8).enumerate() {
        let collides = chunk[0].1;
        if chunk.iter().any(|r| r.1 != collides) {
            return Err(parse_error(
                8 * q,
                "the query's rows disagree on the truth".into(),
            ));
        }
        let p: [DVec3; 8] = std::array::from_fn(|i| chunk[i].0);
        let moving = |i: usize| [p[i], p[i + 4]];
        out.push(if vertex_face {
            SampleQuery::VertexFace {
                query: VertexFace {
                    vertex: moving(0),
                    face: [moving(1), moving(2), moving(3)],
                },
                collides,
            }
        } else {
            SampleQuery::EdgeEdge {
                query: EdgeEdge {
                    a: [moving(0), moving(1)],
                    b: [moving(2), moving(3)],
                },
                collides,
            }
        });
    }
    Ok(())
}

fn parse_row(line: &str) -> std::result::Result<(DVec3, bool), String> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() != 7 {
        return Err(format!("{} fields, expected 7", fields.len()));
    }
    let int = |s: &str| s.parse::<i128>().map_err(|e| format!("{s:?}: {e}"));
    let mut xyz = [0.0; 3];
    for (axis, value) in xyz.iter_mut().enumerate() {
        let (num, den) = (int(fields[2 * axis])?, int(fields[2 * axis + 1])?);
        *value =
            exact_ratio(num, den).ok_or_else(|| format!("{num}/{den} is not exactly an f64"))?;
    }
    let truth = match fields[6] {
        "0" => false,
        "1" => true,
        other => return Err(format!("truth {other:?}, expected 0 or 1")),
    };
    Ok((DVec3::from(xyz), truth))
}

/// `num / den` when it is exactly an f64: the numerator converts without
/// rounding and the denominator is a power of two.
fn exact_ratio(num: i128, den: i128) -> Option<f64> {
    if den <= 0 || den.count_ones() != 1 {
        return None;
    }
    let n = num as f64;
    if n.abs() >= 2f64.powi(126) || n as i128 != num {
        return None;
    }
    let value = n / den as f64;
    (value * den as f64 == n).then_some(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rationals_convert_only_when_exact() {
        assert_eq!(exact_ratio(-8388609, 8388608), Some(-8388609.0 / 8388608.0));
        assert_eq!(exact_ratio(3, 4), Some(0.75));
        assert_eq!(exact_ratio(1, 3), None);
        assert_eq!(exact_ratio((1 << 60) + 1, 1), None);
        assert_eq!(exact_ratio(1, 0), None);
    }

    #[test]
    fn rows_parse_and_bad_rows_are_refused() {
        assert_eq!(
            parse_row("-1,2,3,1,0,1,1"),
            Ok((DVec3::new(-0.5, 3.0, 0.0), true))
        );
        assert!(parse_row("1,1,1,1,1,1").is_err());
        assert!(parse_row("1,1,1,1,1,1,2").is_err());
        assert!(parse_row("1,3,1,1,1,1,0").is_err());
    }
}
