//! What the fixture generators share: a glTF document and its binary chunk, built up view by
//! view, and the GLB they make.

use std::borrow::Cow;

use cdrf_core::glam::Vec3;
use gltf::json;
use json::validation::Checked::Valid;
use json::validation::USize64;

/// The binary chunk and the JSON that describes it.
pub struct Builder {
    pub root: json::Root,
    pub bin: Vec<u8>,
}

impl Builder {
    /// An empty document with its one buffer (its length set by [`Builder::glb`]).
    pub fn new(generator: &str) -> Self {
        let mut builder = Self {
            root: json::Root::default(),
            bin: Vec::new(),
        };
        builder.root.asset.generator = Some(generator.to_owned());
        builder.root.push(json::Buffer {
            byte_length: USize64(0),
            extensions: None,
            extras: Default::default(),
            name: None,
            uri: None,
        });
        builder
    }

    pub fn view(
        &mut self,
        bytes: &[u8],
        target: Option<json::buffer::Target>,
    ) -> json::Index<json::buffer::View> {
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            extensions: None,
            extras: Default::default(),
            name: None,
            target: target.map(Valid),
        })
    }

    pub fn accessor(
        &mut self,
        bytes: &[u8],
        count: usize,
        component_type: json::accessor::ComponentType,
        type_: json::accessor::Type,
        bounds: Option<(Vec3, Vec3)>,
    ) -> json::Index<json::Accessor> {
        let target = if component_type == json::accessor::ComponentType::U32 {
            json::buffer::Target::ElementArrayBuffer
        } else {
            json::buffer::Target::ArrayBuffer
        };
        let view = self.view(bytes, Some(target));
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component_type)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min: bounds.map(|(min, _)| json::Value::from(min.to_array().to_vec())),
            max: bounds.map(|(_, max)| json::Value::from(max.to_array().to_vec())),
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// An accessor of `VEC3` floats, one per point; with their bounds (`positions`, as glTF
    /// requires for `POSITION`) or without.
    pub fn vec3s(&mut self, values: &[Vec3], positions: bool) -> json::Index<json::Accessor> {
        let bounds = positions.then(|| {
            values
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                    (lo.min(p), hi.max(p))
                })
        });
        let bytes = floats(values.iter().flat_map(|v| v.to_array()));
        self.accessor(
            &bytes,
            values.len(),
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec3,
            bounds,
        )
    }

    /// An index accessor of `triangles` (`u32`).
    pub fn triangles(&mut self, triangles: &[[u32; 3]]) -> json::Index<json::Accessor> {
        let bytes: Vec<u8> = triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        self.accessor(
            &bytes,
            3 * triangles.len(),
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
        )
    }

    /// The GLB file: the JSON, then the binary chunk.
    pub fn glb(self) -> Result<Vec<u8>, String> {
        let Self { mut root, bin } = self;
        root.buffers[0].byte_length = USize64::from(bin.len());
        let json_bytes = root
            .to_vec()
            .map_err(|e| format!("encoding the JSON: {e}"))?;
        let length = 12 + 8 + json_bytes.len().next_multiple_of(4) + 8 + bin.len();
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: u32::try_from(length).map_err(|_| "GLB over 4 GiB".to_owned())?,
            },
            json: Cow::Owned(json_bytes),
            bin: Some(Cow::Owned(bin)),
        };
        glb.to_vec().map_err(|e| format!("assembling the GLB: {e}"))
    }
}

/// Little-endian `f32` bytes.
pub fn floats(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// Writes `bytes` to the path given as the one argument, or says how to call it.
pub fn write_out(name: &str, bytes: Result<Vec<u8>, String>) -> std::process::ExitCode {
    let mut args = std::env::args().skip(1);
    let (Some(out), None) = (args.next(), args.next()) else {
        eprintln!("usage: {name} OUT.glb");
        return std::process::ExitCode::FAILURE;
    };
    let result = bytes.and_then(|bytes| {
        std::fs::write(&out, &bytes).map_err(|e| format!("{out}: cannot write: {e}"))?;
        Ok(bytes.len())
    });
    match result {
        Ok(bytes) => {
            println!("{out}: {bytes} bytes");
            std::process::ExitCode::SUCCESS
        }
        Err(error) => {
            eprintln!("{name}: {error}");
            std::process::ExitCode::FAILURE
        }
    }
}
