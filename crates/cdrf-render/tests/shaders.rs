//! Every shader module parses and validates with naga (the shader compiler wgpu uses), without
//! a GPU, as the pipelines compile it (the generated constants and its parts: see
//! `cdrf_render::shaders`): shader errors show up in `cargo test`, reported at the part's own
//! file and line. The shading pass's hand-written light slots are counted against
//! `MAX_SHADOW_LIGHTS`.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use cdrf_render::MAX_SHADOW_LIGHTS;
use cdrf_render::shaders::{ComposedShader, Part, SHADERS, SHADING, Shader, compose};
use naga::valid::{Capabilities, ValidationFlags, Validator};

/// This crate's shader folder.
const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// WebGPU's default `max_inter_stage_shader_variables`: the shading pass's vertex outputs use
/// locations below it.
const MAX_INTER_STAGE_VARIABLES: u32 = 16;

/// Parses and validates a composed shader; `Err` holds naga's diagnostics at the parts' files
/// and lines.
fn validate(name: &str, composed: &ComposedShader) -> Result<naga::Module, String> {
    let source = composed.source();
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        let labels: Vec<_> = e
            .labels()
            .map(|(span, label)| (span.to_range().unwrap_or_default(), label))
            .collect();
        format!("{name}: {}", composed.diagnostic(e.message(), &labels))
    })?;
    Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .map_err(|e| {
            let labels: Vec<_> = e
                .spans()
                .map(|(span, label)| (span.to_range().unwrap_or_default(), label.as_str()))
                .collect();
            // The error and its causes, innermost last.
            let mut message = e.as_inner().to_string();
            let mut cause = std::error::Error::source(e.as_inner());
            while let Some(inner) = cause {
                message.push_str(&format!("\n  = {inner}"));
                cause = inner.source();
            }
            format!("{name}: {}", composed.diagnostic(&message, &labels))
        })?;
    if module.entry_points.is_empty() {
        return Err(format!(
            "{name}: no entry point (@vertex, @fragment or @compute)"
        ));
    }
    Ok(module)
}

fn validate_shader(shader: &Shader) -> Result<naga::Module, String> {
    validate(shader.label, &shader.compose())
}

/// The `*.wgsl` file names directly in `dir`, sorted.
fn wgsl_files(dir: &Path) -> Vec<String> {
    let entries = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list shader folder {}: {e}", dir.display()));
    let mut files: Vec<String> = entries
        .map(|entry| entry.expect("shader folder entry").path())
        .filter(|path: &PathBuf| path.extension().is_some_and(|ext| ext == "wgsl"))
        .map(|path| path.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    files.sort();
    files
}

#[test]
fn every_shader_parses_and_validates() {
    let mut failures = Vec::new();
    for shader in &SHADERS {
        match validate_shader(shader) {
            Ok(module) => {
                let entry_points: Vec<String> = module
                    .entry_points
                    .iter()
                    .map(|ep| format!("{:?} {}", ep.stage, ep.name))
                    .collect();
                println!("validated {}: {}", shader.label, entry_points.join(", "));
            }
            Err(report) => failures.push(report),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} shader(s) failed:\n\n{}",
        failures.len(),
        SHADERS.len(),
        failures.join("\n\n")
    );
}

/// Every WGSL file in the crate's folder is a part of some shader, so none is left out of
/// validation.
#[test]
fn the_shader_folder_holds_exactly_the_composed_parts() {
    let composed: BTreeSet<String> = SHADERS
        .iter()
        .flat_map(|shader| shader.parts)
        .map(|part| part.path.trim_start_matches("shaders/").to_string())
        .collect();
    assert_eq!(
        wgsl_files(Path::new(SHADER_DIR)),
        composed.into_iter().collect::<Vec<_>>(),
        "a WGSL file was added to or removed from {SHADER_DIR}: list it among a shader's parts \
         in src/shaders.rs"
    );
}

/// `SHADING`'s parts with `path`'s text replaced.
fn shading_with(path: &str, source: &'static str) -> ComposedShader {
    let parts: Vec<Part> = SHADING
        .parts
        .iter()
        .map(|part| {
            if part.path == path {
                Part {
                    path: part.path,
                    source,
                }
            } else {
                *part
            }
        })
        .collect();
    assert!(
        parts.iter().any(|part| part.source == source),
        "{path} is a part of SHADING"
    );
    compose(&parts)
}

/// The 1-based line of `needle`'s first occurrence in `text`.
fn line_of(text: &str, needle: &str) -> usize {
    text[..text.find(needle).expect("needle in text")]
        .matches('\n')
        .count()
        + 1
}

/// A part broken on purpose is reported at its own file and line, not at a line of the
/// composed source.
#[test]
fn a_broken_part_is_reported_at_its_own_file_and_line() {
    let specular = SHADING
        .parts
        .iter()
        .find(|part| part.path == "shaders/specular.wgsl")
        .expect("specular part")
        .source;
    // A syntax error: a missing semicolon.
    let broken: &'static str = specular
        .replacen(
            "let half = normalize(half_sum);",
            "let half = normalize(half_sum)",
            1,
        )
        .leak();
    let line = line_of(broken, "let half = normalize(half_sum)") + 1;
    let composed = shading_with("shaders/specular.wgsl", broken);
    let report = validate("broken", &composed).expect_err("a syntax error");
    println!("{report}");
    assert!(
        report.contains(&format!("--> shaders/specular.wgsl:{line}:")),
        "{report}"
    );
    assert!(
        report.contains("let cos_half = dot(normal, half);"),
        "{report}"
    );

    // A validation error: a call with the wrong argument type.
    let broken: &'static str = specular
        .replacen("smith_g1(cos_phi, alpha)", "smith_g1(cos_phi, 1u)", 1)
        .leak();
    let line = line_of(broken, "smith_g1(cos_phi, 1u)");
    let composed = shading_with("shaders/specular.wgsl", broken);
    let report = validate("broken", &composed).expect_err("a type error");
    println!("{report}");
    assert!(
        report.contains(&format!("--> shaders/specular.wgsl:{line}:")),
        "{report}"
    );
    let composed_line = line_of(composed.source(), "smith_g1(cos_phi, 1u)");
    assert_ne!(
        composed_line, line,
        "the part does not start the composed source"
    );
    assert!(!report.contains(&format!(":{composed_line}:")), "{report}");
}

/// The struct `name`'s members in `module`.
fn members<'a>(module: &'a naga::Module, name: &str) -> &'a [naga::StructMember] {
    module
        .types
        .iter()
        .find_map(|(_, ty)| match &ty.inner {
            naga::TypeInner::Struct { members, .. } if ty.name.as_deref() == Some(name) => {
                Some(members.as_slice())
            }
            _ => None,
        })
        .unwrap_or_else(|| panic!("struct {name} declared"))
}

/// The names of `members` that start with `prefix`.
fn named<'a>(members: &'a [naga::StructMember], prefix: &str) -> Vec<&'a str> {
    members
        .iter()
        .filter_map(|m| m.name.as_deref())
        .filter(|name| name.starts_with(prefix))
        .collect()
}

/// The shading pass writes out one slot per shadowed light (stage inputs and outputs hold no
/// arrays): as many as `MAX_SHADOW_LIGHTS` in `VertexTermsIn`, `VertexOut`, `slot_terms`'s
/// cases and `light_curvatures_per_mm`'s vector, within WebGPU's inter-stage limit.
#[test]
fn the_shading_pass_has_a_slot_per_shadowed_light() {
    let module = validate_shader(&SHADING).expect("the shading shader validates");
    let slots: Vec<String> = (0..MAX_SHADOW_LIGHTS).map(|k| k.to_string()).collect();
    for name in ["VertexTermsIn", "VertexOut"] {
        let members = members(&module, name);
        for field in ["visibility_", "through_"] {
            let found: Vec<&str> = named(members, field)
                .into_iter()
                .map(|n| n.trim_start_matches(field))
                .collect();
            assert_eq!(found, slots, "{name}.{field}*");
        }
    }
    let out = members(&module, "VertexOut");
    let curvatures = out
        .iter()
        .find(|m| m.name.as_deref() == Some("light_curvatures_per_mm"))
        .expect("VertexOut.light_curvatures_per_mm");
    match module.types[curvatures.ty].inner {
        naga::TypeInner::Vector { size, .. } => {
            assert_eq!(size as usize, MAX_SHADOW_LIGHTS, "light_curvatures_per_mm")
        }
        ref other => panic!("light_curvatures_per_mm is {other:?}"),
    }
    let highest = out
        .iter()
        .filter_map(|m| match m.binding {
            Some(naga::Binding::Location { location, .. }) => Some(location),
            _ => None,
        })
        .max()
        .unwrap();
    assert!(
        highest < MAX_INTER_STAGE_VARIABLES,
        "VertexOut uses location {highest}"
    );

    let (_, slot_terms) = module
        .functions
        .iter()
        .find(|(_, f)| f.name.as_deref() == Some("slot_terms"))
        .expect("fn slot_terms");
    let cases = slot_terms
        .body
        .iter()
        .find_map(|statement| match statement {
            naga::Statement::Switch { cases, .. } => Some(cases),
            _ => None,
        })
        .expect("slot_terms switches on the slot");
    let values: Vec<u32> = cases
        .iter()
        .filter_map(|case| match case.value {
            naga::SwitchValue::U32(value) => Some(value),
            _ => None,
        })
        .collect();
    assert_eq!(values, (0..MAX_SHADOW_LIGHTS as u32).collect::<Vec<_>>());
}
