//! The Rust ↔ WGSL contract, checked with naga on the CPU (no adapter needed):
//!
//! - every assembled shader module parses and validates;
//! - every module-scope constant comes from Rust (`render::shader::shared_constants`) with
//!   Rust's value, and no shader file declares one of its own;
//! - every struct Rust writes into a buffer (`render::gpu_data`) has the size, member offsets
//!   and member types of its WGSL twin in the assembled module, and each buffer binding holds
//!   the type Rust assumes;
//! - the ring vertex's buffer layout (locations, formats, offsets) matches the vertex input;
//! - compute workgroup sizes are the ones Rust's dispatch counts divide by.
//!
//! The checker is shown to fail on a deliberately swapped struct, a wrong constant, a
//! hand-written constant and a wrong vertex offset.

use bytemuck::{Pod, Zeroable};
use globe::render::contracts::{PassContract, pass_contracts};
use globe::render::gpu_data::{GpuStruct, StructLayout};
use globe::render::shader::shared_constants;

fn parse(file: &str, source: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| format!("{file}: {}", e.emit_to_string(source)))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .map_err(|e| format!("{file}: {}", e.emit_to_string(source)))?;
    Ok(module)
}

/// A naga type written as WGSL spells it.
fn wgsl_name(module: &naga::Module, ty: naga::Handle<naga::Type>) -> String {
    use naga::TypeInner as T;
    let scalar = |s: &naga::Scalar| match (s.kind, s.width) {
        (naga::ScalarKind::Float, 4) => "f32".to_string(),
        (naga::ScalarKind::Uint, 4) => "u32".to_string(),
        (naga::ScalarKind::Sint, 4) => "i32".to_string(),
        (kind, width) => format!("{kind:?}{width}"),
    };
    let t = &module.types[ty];
    match &t.inner {
        T::Scalar(s) => scalar(s),
        T::Vector { size, scalar: s } => format!("vec{}<{}>", *size as u8, scalar(s)),
        T::Matrix {
            columns,
            rows,
            scalar: s,
        } => format!("mat{}x{}<{}>", *columns as u8, *rows as u8, scalar(s)),
        T::Array { base, size, .. } => match size {
            naga::ArraySize::Constant(n) => format!("array<{}, {n}>", wgsl_name(module, *base)),
            _ => format!("array<{}>", wgsl_name(module, *base)),
        },
        T::Struct { .. } => t
            .name
            .clone()
            .unwrap_or_else(|| "<anonymous struct>".into()),
        other => format!("{other:?}"),
    }
}

/// The members and size of the named struct in the module.
fn wgsl_struct<'m>(
    module: &'m naga::Module,
    name: &str,
) -> Option<(&'m [naga::StructMember], usize)> {
    module
        .types
        .iter()
        .find_map(|(_, t)| match (&t.name, &t.inner) {
            (Some(n), naga::TypeInner::Struct { members, span }) if n == name => {
                Some((members.as_slice(), *span as usize))
            }
            _ => None,
        })
}

/// Differences between Rust's layout of a struct and its WGSL twin (empty: they agree).
fn struct_problems(file: &str, module: &naga::Module, rust: &StructLayout) -> Vec<String> {
    let mut problems = Vec::new();
    let Some((members, span)) = wgsl_struct(module, rust.wgsl_name) else {
        return vec![format!(
            "{file}: no struct {} in the module",
            rust.wgsl_name
        )];
    };
    let name = rust.wgsl_name;
    if span != rust.size {
        problems.push(format!(
            "{file}: {name} is {span} bytes in WGSL, {} in Rust",
            rust.size
        ));
    }
    let wgsl_fields: Vec<_> = members
        .iter()
        .filter(|m| !m.name.as_deref().unwrap_or("_").starts_with('_'))
        .collect();
    for m in &wgsl_fields {
        let member = m.name.as_deref().unwrap_or_default();
        let Some(f) = rust.fields.iter().find(|f| f.name == member) else {
            problems.push(format!("{file}: {name}.{member} has no Rust twin"));
            continue;
        };
        if f.offset != m.offset as usize {
            problems.push(format!(
                "{file}: {name}.{member} is at byte {} in WGSL, {} in Rust",
                m.offset, f.offset
            ));
        }
        let wgsl_type = wgsl_name(module, m.ty);
        if f.wgsl_type != wgsl_type {
            problems.push(format!(
                "{file}: {name}.{member} is {wgsl_type} in WGSL, Rust has {} ({} bytes)",
                f.wgsl_type, f.size
            ));
        }
    }
    for f in &rust.fields {
        if !wgsl_fields
            .iter()
            .any(|m| m.name.as_deref() == Some(f.name))
        {
            problems.push(format!("{file}: Rust's {name}.{} is not in WGSL", f.name));
        }
    }
    problems
}

fn constant_problems(file: &str, module: &naga::Module) -> Vec<String> {
    let shared = shared_constants();
    let mut problems = Vec::new();
    for (_, c) in module.constants.iter() {
        let Some(name) = c.name.as_deref() else {
            continue;
        };
        let Some(rust) = shared.iter().find(|s| s.name == name) else {
            problems.push(format!(
                "{file}: module-scope const {name} is not generated from Rust \
                 (add it to render::shader::shared_constants)"
            ));
            continue;
        };
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) if v == rust.value => {}
            ref other => problems.push(format!(
                "{file}: const {name} is {other:?} in WGSL, {}u in Rust",
                rust.value
            )),
        }
    }
    problems
}

fn binding_problems(file: &str, module: &naga::Module, contract: &PassContract) -> Vec<String> {
    let mut problems = Vec::new();
    for b in &contract.buffers {
        let found = module.global_variables.iter().find(|(_, g)| {
            g.binding
                .as_ref()
                .is_some_and(|r| r.group == b.group && r.binding == b.binding)
        });
        match found {
            None => problems.push(format!(
                "{file}: nothing at @group({}) @binding({})",
                b.group, b.binding
            )),
            Some((_, g)) => {
                let ty = wgsl_name(module, g.ty);
                if ty != b.wgsl_type {
                    problems.push(format!(
                        "{file}: @group({}) @binding({}) holds {ty}, Rust writes {}",
                        b.group, b.binding, b.wgsl_type
                    ));
                }
            }
        }
    }
    problems
}

fn vertex_problems(file: &str, module: &naga::Module, contract: &PassContract) -> Vec<String> {
    let Some((layout, attributes)) = &contract.vertex else {
        return Vec::new();
    };
    let mut problems = Vec::new();
    let Some((members, _)) = wgsl_struct(module, layout.wgsl_name) else {
        return vec![format!("{file}: no vertex struct {}", layout.wgsl_name)];
    };
    for m in members {
        let Some(naga::Binding::Location { location, .. }) = m.binding else {
            continue;
        };
        let member = m.name.as_deref().unwrap_or_default();
        let Some(attribute) = attributes.iter().find(|a| a.shader_location == location) else {
            problems.push(format!(
                "{file}: @location({location}) {member} has no attribute"
            ));
            continue;
        };
        let format_type = match attribute.format {
            wgpu::VertexFormat::Float32 => "f32",
            wgpu::VertexFormat::Float32x2 => "vec2<f32>",
            wgpu::VertexFormat::Float32x3 => "vec3<f32>",
            wgpu::VertexFormat::Float32x4 => "vec4<f32>",
            wgpu::VertexFormat::Uint32 => "u32",
            wgpu::VertexFormat::Sint32 => "i32",
            other => {
                problems.push(format!("{file}: attribute format {other:?} not mapped"));
                continue;
            }
        };
        let wgsl_type = wgsl_name(module, m.ty);
        if format_type != wgsl_type {
            problems.push(format!(
                "{file}: @location({location}) {member} is {wgsl_type}, the buffer gives {format_type}"
            ));
        }
        match layout.fields.iter().find(|f| f.name == member) {
            None => problems.push(format!("{file}: vertex input {member} has no Rust field")),
            Some(f) => {
                if f.offset as u64 != attribute.offset {
                    problems.push(format!(
                        "{file}: @location({location}) {member} reads byte {}, Rust stores it at {}",
                        attribute.offset, f.offset
                    ));
                }
                if f.wgsl_type != wgsl_type {
                    problems.push(format!(
                        "{file}: vertex input {member} is {wgsl_type}, Rust has {}",
                        f.wgsl_type
                    ));
                }
            }
        }
    }
    problems
}

/// Everything wrong with one pass (empty: Rust and WGSL agree).
fn check(contract: &PassContract) -> Vec<String> {
    let file = contract.file;
    let module = match parse(file, &contract.source) {
        Ok(m) => m,
        Err(e) => return vec![e],
    };
    let mut problems = constant_problems(file, &module);
    for s in &contract.structs {
        problems.extend(struct_problems(file, &module, s));
    }
    problems.extend(binding_problems(file, &module, contract));
    problems.extend(vertex_problems(file, &module, contract));
    if let Some(size) = contract.workgroup_size {
        match module.entry_points.iter().find(|e| e.name == "cs_main") {
            None => problems.push(format!("{file}: no cs_main")),
            Some(e) if e.workgroup_size != size => problems.push(format!(
                "{file}: @workgroup_size{:?}, Rust dispatches by {size:?}",
                e.workgroup_size
            )),
            Some(_) => {}
        }
    }
    problems
}

fn contract(file: &str) -> PassContract {
    pass_contracts()
        .into_iter()
        .find(|c| c.file == file)
        .unwrap_or_else(|| panic!("no contract for {file}"))
}

#[test]
fn every_assembled_module_keeps_the_contract() {
    let contracts = pass_contracts();
    assert_eq!(
        contracts.len(),
        6,
        "terrain, analytic fill, DEM fill, sky, normals, water cull"
    );
    for c in &contracts {
        let problems = check(c);
        assert!(problems.is_empty(), "{}", problems.join("\n"));
        // Something was really compared.
        assert!(c.structs.iter().all(|s| !s.fields.is_empty()), "{}", c.file);
        println!(
            "{}: {} structs, {} buffers, constants {}",
            c.file,
            c.structs.len(),
            c.buffers.len(),
            shared_constants().len()
        );
    }
}

#[test]
fn shader_files_declare_no_constants_of_their_own() {
    // Every `const` at module scope must come from the generated prelude: a copy in a file
    // would either clash with it or drift from Rust.
    for (file, body) in [
        ("terrain.wgsl", globe::render::shader::TERRAIN),
        ("fill_analytic.wgsl", globe::render::shader::FILL_ANALYTIC),
        ("fill_dem.wgsl", globe::render::shader::FILL_DEM),
        ("water_cull.wgsl", globe::render::shader::WATER_CULL),
        (
            "common/map_transform.wgsl",
            include_str!("../../shaders/common/map_transform.wgsl"),
        ),
    ] {
        for (n, line) in body.lines().enumerate() {
            assert!(
                !line.starts_with("const "),
                "{file}:{}: module-scope `{line}`; generate it from Rust instead",
                n + 1
            );
        }
    }
}

/// Builtin trigonometry a shader may still call, with why its precision is enough: Vulkan lets a
/// driver's `sin`/`cos` be off by 2^-11 absolute and `atan2`/`acos` by 4096 ulp, and NVIDIA's
/// `sin` returns 0 for the angle of a fine level's texel (`shaders/common/trig.wgsl`).
const BUILTIN_TRIG_ALLOWED: [(&str, &str, &str); 2] = [
    // The paper's eq. 4, kept as the baseline the stable form is measured against.
    ("common/map_transform.wgsl", "map_transform_direct", "acos"),
    // A relief-map lookup: 1024 columns need 6e-3 rad; 4096 ulp of π is 1e-3 rad.
    ("terrain.wgsl", "relief_at_world", "atan2"),
];

#[test]
fn shaders_call_no_builtin_trig_where_precision_matters() {
    let builtins = [
        "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
    ];
    let files = [
        ("terrain.wgsl", globe::render::shader::TERRAIN),
        ("fill_analytic.wgsl", globe::render::shader::FILL_ANALYTIC),
        ("fill_dem.wgsl", globe::render::shader::FILL_DEM),
        ("fill_normals.wgsl", globe::render::shader::FILL_NORMALS),
        ("sky.wgsl", globe::render::shader::SKY),
        (
            "common/look.wgsl",
            include_str!("../../shaders/common/look.wgsl"),
        ),
        (
            "common/trig.wgsl",
            include_str!("../../shaders/common/trig.wgsl"),
        ),
        (
            "common/map_transform.wgsl",
            include_str!("../../shaders/common/map_transform.wgsl"),
        ),
        (
            "common/noise.wgsl",
            include_str!("../../shaders/common/noise.wgsl"),
        ),
        (
            "common/detail_fill.wgsl",
            include_str!("../../shaders/common/detail_fill.wgsl"),
        ),
    ];
    let mut found = Vec::new();
    let mut seen_allowed = Vec::new();
    for (file, body) in files {
        let mut function = "";
        for (n, line) in body.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if let Some(rest) = code.trim_start().strip_prefix("fn ") {
                function = rest.split('(').next().unwrap_or("").trim();
            }
            let bytes = code.as_bytes();
            for (i, _) in code.match_indices('(') {
                let start = code[..i]
                    .rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .map_or(0, |p| p + 1);
                let name = &code[start..i];
                let member = start > 0 && bytes[start - 1] == b'.';
                if !builtins.contains(&name) || member {
                    continue;
                }
                if BUILTIN_TRIG_ALLOWED.contains(&(file, function, name)) {
                    seen_allowed.push((file, function, name));
                } else {
                    found.push(format!("{file}:{} in {function}: {}", n + 1, line.trim()));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "builtin trig whose precision is up to the driver (use trig.wgsl's forms):\n{}",
        found.join("\n")
    );
    // The scan does see calls: each allowed one is found where it is listed.
    for allowed in BUILTIN_TRIG_ALLOWED {
        assert!(
            seen_allowed.contains(&allowed),
            "{allowed:?} is allowed but the scan did not find it (moved, or the scan is blind)"
        );
    }
}

/// `LevelUniforms` with its first two fields swapped: what a careless edit of the Rust side
/// would produce.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LevelUniformsSwapped {
    grid_y_viewer: f32,
    grid_x_viewer: f32,
    inv_dphi: f32,
    inv_dtheta: f32,
    dtheta_rad: f32,
    _pad: [f32; 3],
}
globe::gpu_struct!(LevelUniformsSwapped as "LevelUniforms" {
    grid_x_viewer, grid_y_viewer, inv_dphi, inv_dtheta, dtheta_rad,
});

/// `DemFillParams` with `cols` declared as f32 instead of i32 (same size, wrong type).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct DemFillParamsWrongType {
    base: [i32; 2],
    frac: [f32; 2],
    step: [f32; 2],
    slot0: [u32; 2],
    extent: [u32; 2],
    layer: u32,
    size: u32,
    page_base: u32,
    tiles_x: u32,
    cols: f32,
    rows: i32,
    tile_size: i32,
    wraps: u32,
    cap_north: [f32; 2],
    cap_south: [f32; 2],
    decode: [f32; 2],
    offset: [u32; 2],
    sea_m: f32,
    code_ref: i32,
    frac_lo: [f32; 2],
    anchor_m: f32,
    relative: u32,
}
globe::gpu_struct!(DemFillParamsWrongType as "DemFillParams" {
    base, frac, step, slot0, extent, layer, size, page_base, tiles_x, cols, rows, tile_size,
    wraps, cap_north, cap_south, decode, offset, sea_m, code_ref, frac_lo, anchor_m, relative,
});

#[test]
fn a_swapped_or_mistyped_field_fails_the_contract() {
    let mut terrain = contract("terrain.wgsl");
    terrain.structs[1] = LevelUniformsSwapped::layout();
    let problems = check(&terrain);
    println!("swapped:\n{}", problems.join("\n"));
    assert!(
        problems
            .iter()
            .any(|p| p.contains("LevelUniforms.grid_x_viewer is at byte 0 in WGSL, 4 in Rust")),
        "{problems:?}"
    );
    assert!(
        problems
            .iter()
            .any(|p| p.contains("LevelUniforms.grid_y_viewer is at byte 4 in WGSL, 0 in Rust"))
    );

    let mut dem = contract("fill_dem.wgsl");
    dem.structs[0] = DemFillParamsWrongType::layout();
    let problems = check(&dem);
    println!("mistyped:\n{}", problems.join("\n"));
    assert_eq!(
        problems,
        ["fill_dem.wgsl: DemFillParams.cols is i32 in WGSL, Rust has f32 (4 bytes)"]
    );
}

#[test]
fn a_wrong_or_hand_written_constant_fails_the_contract() {
    let mut dem = contract("fill_dem.wgsl");
    let generated = format!("const NO_SLOT: u32 = {}u;", u32::MAX);
    assert!(dem.source.contains(&generated));
    dem.source = dem
        .source
        .replace(&generated, "const NO_SLOT: u32 = 0xffffu;");
    let problems = check(&dem);
    println!("wrong:\n{}", problems.join("\n"));
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].contains("const NO_SLOT is Literal(U32(65535)) in WGSL, 4294967295u in Rust")
    );

    let mut terrain = contract("terrain.wgsl");
    terrain.source.push_str("\nconst SEA_LEVEL_M: f32 = 0.0;\n");
    let problems = check(&terrain);
    println!("hand-written:\n{}", problems.join("\n"));
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(problems[0].contains("SEA_LEVEL_M is not generated from Rust"));

    // A workgroup size typed into the file instead of the generated one.
    let mut fill = contract("fill_analytic.wgsl");
    fill.source = fill.source.replace(
        "@workgroup_size(WORKGROUP_SIZE, WORKGROUP_SIZE, 1)",
        "@workgroup_size(16, 16, 1)",
    );
    let problems = check(&fill);
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(problems[0].contains("@workgroup_size[16, 16, 1], Rust dispatches by [8, 8, 1]"));
}

#[test]
fn a_wrong_vertex_offset_fails_the_contract() {
    const SHIFTED: [wgpu::VertexAttribute; 6] = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32, 2 => Float32, 3 => Float32, 5 => Float32, 4 => Uint32
    ];
    let mut terrain = contract("terrain.wgsl");
    terrain.vertex.as_mut().expect("terrain has vertices").1 = &SHIFTED;
    let problems = check(&terrain);
    println!("vertex:\n{}", problems.join("\n"));
    assert!(
        problems
            .iter()
            .any(|p| p.contains("@location(4) level reads byte 28, Rust stores it at 24")),
        "{problems:?}"
    );
}
