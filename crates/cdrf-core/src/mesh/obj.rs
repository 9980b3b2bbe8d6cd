//! OBJ loading through `tobj`.

use std::path::Path;

use glam::{Vec2, Vec3};

use super::{LoadError, MeshData};

/// Reads every object of an OBJ file into unchecked [`MeshData`].
pub(super) fn load(path: &Path) -> Result<MeshData, LoadError> {
    let bytes = crate::input_file::read_regular(path, crate::input_file::MAX_INPUT_FILE_BYTES)
        .map_err(|source| LoadError::Io {
            path: path.to_owned(),
            source,
        })?;
    let text = utf8_text(&bytes).map_err(|line| LoadError::NotText {
        path: path.to_owned(),
        line,
    })?;
    check_faces(&text).map_err(|(line, problem)| LoadError::ObjFace {
        path: path.to_owned(),
        line,
        problem,
    })?;
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials are irrelevant here: a loader that fails only records a material error.
    let (models, _materials) = tobj::load_obj_buf(&mut text.as_bytes(), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|source| LoadError::Obj {
        path: path.to_owned(),
        source,
    })?;

    let mut data = MeshData::default();
    let mut normals = Vec::new();
    let mut all_normals = true;
    let mut uvs = Vec::new();
    let mut all_uvs = true;
    for model in &models {
        let mesh = &model.mesh;
        let base = data.positions.len();
        let count = mesh.positions.len() / 3;
        data.positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if mesh.normals.len() == 3 * count {
            normals.extend(
                mesh.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        } else {
            // Mark as missing: computed by the repair step.
            normals.extend(std::iter::repeat_n(Vec3::ZERO, count));
            all_normals = false;
        }
        if mesh.texcoords.len() == 2 * count {
            uvs.extend(
                mesh.texcoords
                    .chunks_exact(2)
                    .map(|t| Vec2::new(t[0], 1.0 - t[1])),
            );
        } else {
            all_uvs = false;
        }
        // tobj checks indices against the model's own vertices; offset them into the shared
        // arrays, leaving anything unexpected out of range for the repair step to count.
        let offset = |i: u32| {
            if (i as usize) < count {
                u32::try_from(base + i as usize).unwrap_or(u32::MAX)
            } else {
                u32::MAX
            }
        };
        data.triangles.extend(
            mesh.indices
                .chunks_exact(3)
                .map(|t| [offset(t[0]), offset(t[1]), offset(t[2])]),
        );
    }
    let any_normals = normals.iter().any(|&n| n != Vec3::ZERO);
    data.normals = (all_normals || any_normals).then_some(normals);
    data.uvs = (all_uvs && !uvs.is_empty()).then_some(uvs);
    Ok(data)
}

/// Checks every face line before tobj reads it: each index must name an element that exists
/// (positive: 1 up to the file's count; negative: back from the count so far) and every corner
/// of a face must have the same format. tobj indexes with such values unchecked (its index
/// arithmetic overflows), so they are refused here with the line.
fn check_faces(text: &str) -> Result<(), (usize, String)> {
    let count = |prefix: &str| {
        text.lines()
            .filter(|line| line.split_whitespace().next() == Some(prefix))
            .count() as i64
    };
    let totals = [count("v"), count("vt"), count("vn")];
    let mut so_far = [0i64; 3];
    let names = ["vertex", "texture coordinate", "normal"];
    for (index, line) in text.lines().enumerate() {
        let number = index + 1;
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => so_far[0] += 1,
            Some("vt") => so_far[1] += 1,
            Some("vn") => so_far[2] += 1,
            Some("f") => {
                let mut format: Option<[bool; 3]> = None;
                for corner in tokens {
                    let parts: Vec<&str> = corner.split('/').collect();
                    if parts.len() > 3 {
                        return Err((
                            number,
                            format!("face corner `{corner}` has more than 3 parts"),
                        ));
                    }
                    let mut present = [false; 3];
                    for (kind, part) in parts.iter().enumerate() {
                        if part.is_empty() {
                            if kind == 0 {
                                return Err((
                                    number,
                                    format!("face corner `{corner}` has no vertex"),
                                ));
                            }
                            continue;
                        }
                        present[kind] = true;
                        let value: i64 = part.parse().map_err(|_| {
                            (
                                number,
                                format!("face corner `{corner}`: `{part}` is not an index"),
                            )
                        })?;
                        let valid = if value > 0 {
                            value <= totals[kind]
                        } else {
                            value < 0 && -value <= so_far[kind]
                        };
                        if !valid {
                            return Err((
                                number,
                                format!(
                                    "face corner `{corner}`: {} index {value} does not exist ({} in the file, {} so far)",
                                    names[kind], totals[kind], so_far[kind]
                                ),
                            ));
                        }
                    }
                    match format {
                        None => format = Some(present),
                        Some(first) if first != present => {
                            return Err((
                                number,
                                format!(
                                    "face corner `{corner}` has another format than the face's first"
                                ),
                            ));
                        }
                        Some(_) => {}
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// The file as text: comment lines (`#`) may hold any bytes (read lossily, an editor's Latin-1
/// comment is harmless); elsewhere invalid UTF-8 is refused with its 1-based line.
fn utf8_text(bytes: &[u8]) -> Result<String, usize> {
    if let Ok(text) = std::str::from_utf8(bytes) {
        return Ok(text.to_owned());
    }
    let mut text = String::with_capacity(bytes.len());
    for (index, line) in bytes.split_inclusive(|&b| b == b'\n').enumerate() {
        match std::str::from_utf8(line) {
            Ok(line) => text.push_str(line),
            Err(_) if line.trim_ascii_start().starts_with(b"#") => {
                text.push_str(&String::from_utf8_lossy(line));
            }
            Err(_) => return Err(index + 1),
        }
    }
    Ok(text)
}
