//! OBJ loading through `tobj`, with a parallel reader for the plainest files.

use std::path::Path;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

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
    if let Some(data) = positions_and_triangles(&text) {
        return Ok(data);
    }
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

/// Files of `v x y z` and `f i j k …` lines only (plus comments and blank lines: the shape of
/// scanned and exported meshes at their largest) are read here, in parallel: a 1M-vertex OBJ
/// takes 1.0 s in tobj, which is single-threaded, and most of `cdrf-curvature`'s run. The result
/// is exactly tobj's in single-index mode (vertices in the order faces first use them, unused
/// ones dropped, polygons fanned from their first corner, 1- and 2-corner faces ignored);
/// `tests/obj_fast_path.rs` holds the two against each other. Anything else (`vt`, `vn`, `o`,
/// `g`, materials, a `w` or colour on a vertex, a face with `/`, an unparsable number, no faces)
/// returns `None` and goes through tobj, as does an index that names no vertex (so the error
/// is [`check_faces`]'s, with its line).
fn positions_and_triangles(text: &str) -> Option<MeshData> {
    let chunks = line_chunks(text, 1 << 20);
    // Pass 1: the vertex count before each chunk (relative indices count back from it).
    let counts: Option<Vec<usize>> = chunks
        .par_iter()
        .map(|chunk| {
            let mut count = 0;
            for line in chunk.lines() {
                match line.split_whitespace().next() {
                    Some("v") => count += 1,
                    Some("f") => {}
                    Some(token) if token.starts_with('#') => {}
                    None => {}
                    Some(_) => return None,
                }
            }
            Some(count)
        })
        .collect();
    let mut before = counts?;
    let mut total = 0;
    for count in &mut before {
        total += std::mem::replace(count, total);
    }
    // Pass 2: positions and (file-index) triangles per chunk.
    type Chunk = (Vec<Vec3>, Vec<[u32; 3]>);
    let parsed: Option<Vec<Chunk>> = chunks
        .par_iter()
        .zip(&before)
        .map(|(chunk, &before)| {
            let (mut positions, mut triangles) = (Vec::new(), Vec::new());
            let mut corners: Vec<u32> = Vec::new();
            for line in chunk.lines() {
                let mut tokens = line.split_whitespace();
                match tokens.next() {
                    Some("v") => {
                        let mut xyz = [0.0f32; 3];
                        for value in &mut xyz {
                            *value = tokens.next()?.parse().ok()?;
                        }
                        if tokens.next().is_some() {
                            return None;
                        }
                        positions.push(Vec3::from_array(xyz));
                    }
                    Some("f") => {
                        let so_far = (before + positions.len()) as i64;
                        corners.clear();
                        for token in tokens {
                            let index: i64 = token.parse().ok()?;
                            let index = if index < 0 { so_far + index } else { index - 1 };
                            corners.push(u32::try_from(index).ok()?);
                        }
                        if corners.is_empty() {
                            return None; // tobj refuses a face without corners
                        }
                        for pair in corners.windows(2).skip(1) {
                            triangles.push([corners[0], pair[0], pair[1]]);
                        }
                    }
                    _ => {}
                }
            }
            Some((positions, triangles))
        })
        .collect();
    let parsed = parsed?;
    let triangle_count: usize = parsed.iter().map(|(_, t)| t.len()).sum();
    if triangle_count == 0 {
        return None;
    }
    let mut file_positions = Vec::with_capacity(total);
    let mut file_triangles = Vec::with_capacity(triangle_count);
    for (positions, triangles) in parsed {
        file_positions.extend(positions);
        file_triangles.extend(triangles);
    }
    // tobj's single index: vertices numbered in the order the faces first use them.
    let mut new_index = vec![u32::MAX; file_positions.len()];
    let mut positions = Vec::new();
    let mut triangles = file_triangles;
    for triangle in &mut triangles {
        for corner in triangle.iter_mut() {
            let slot = new_index.get_mut(*corner as usize)?;
            if *slot == u32::MAX {
                *slot = u32::try_from(positions.len()).ok()?;
                positions.push(file_positions[*corner as usize]);
            }
            *corner = *slot;
        }
    }
    Some(MeshData {
        positions,
        normals: None,
        uvs: None,
        triangles,
    })
}

/// `text` cut into pieces of about `bytes` bytes, each ending after a newline (the last one
/// wherever the text ends).
fn line_chunks(text: &str, bytes: usize) -> Vec<&str> {
    let mut chunks = Vec::new();
    let mut rest = text;
    while !rest.is_empty() {
        let end = match rest.as_bytes().iter().skip(bytes).position(|&b| b == b'\n') {
            Some(offset) => bytes + offset + 1,
            None => rest.len(),
        };
        let (chunk, tail) = rest.split_at(end);
        chunks.push(chunk);
        rest = tail;
    }
    chunks
}

/// Checks every face line before tobj reads it: each index must name an element that exists
/// (positive: 1 up to the file's count; negative: back from the count so far) and every corner
/// of a face must have the same format. tobj indexes with such values unchecked (its index
/// arithmetic overflows), so they are refused here with the line.
fn check_faces(text: &str) -> Result<(), (usize, String)> {
    // One pass for the three totals (positive indices may point past the face's line).
    let mut totals = [0i64; 3];
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => totals[0] += 1,
            Some("vt") => totals[1] += 1,
            Some("vn") => totals[2] += 1,
            _ => {}
        }
    }
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
                    if corner.split('/').nth(3).is_some() {
                        return Err((
                            number,
                            format!("face corner `{corner}` has more than 3 parts"),
                        ));
                    }
                    let mut present = [false; 3];
                    for (kind, part) in corner.split('/').enumerate() {
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
                            value < 0
                                && value.checked_neg().is_some_and(|back| back <= so_far[kind])
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
