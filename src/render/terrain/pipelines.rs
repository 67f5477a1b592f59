//! The terrain pass's pipelines: the clipmap's variants, the planar methods', the
//! wireframe overlay's and the pass-through, built from one set of parts.

use crate::clipmap::{ClipmapSettings, RingVertex};
use crate::look::LookSettings;
use crate::render::formats::DEPTH_FORMAT;
use crate::render::gpu_data::{PLACED_VERTEX_ATTRIBUTES, PlacedVertex, RING_VERTEX_ATTRIBUTES};
use crate::render::placement::Placement;
use crate::render::shader;
use crate::terrain::Terrain;

use super::shading::Shading;

/// The clipmap's pipelines, one per `clipmap::draw_list::Variant` (plain, blend band,
/// morphing levels): with the water's shading and, where the water cull may choose, without it.
pub(super) struct ClipmapPipelines {
    pub(super) wet: [wgpu::RenderPipeline; 3],
    /// With water, drawn by indirect draws the cull gives an instance where it proved the
    /// level dry (None: no water, or a draw that pulls its own indices).
    pub(super) dry: Option<[wgpu::RenderPipeline; 3]>,
}

/// Pipelines of a frame with a planar method.
pub(super) struct PlanarPipelines {
    pub(super) clipmap_cut: ClipmapPipelines,
    pub(super) geomip: wgpu::RenderPipeline,
}

/// The projected grid's pipelines: the mesh as placed, and its fragments ray cast where the
/// error buffer's ρ exceeds γ.
pub(super) struct GridPipelines {
    pub(super) plain: wgpu::RenderPipeline,
    pub(super) ray_cast: wgpu::RenderPipeline,
}

/// The wireframe overlay's pipelines: the same shading, drawn without an index buffer (the
/// vertex stages read the indices and give each corner its barycentric coordinate).
pub(super) struct WirePipelines {
    pub(super) clipmap: ClipmapPipelines,
    pub(super) clipmap_cut: ClipmapPipelines,
    pub(super) geomip: wgpu::RenderPipeline,
    /// The projected grid's, without and with ray casting (built when first needed).
    pub(super) grid: Option<GridPipelines>,
}

/// What a terrain pipeline's vertex stage reads from vertex buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum VertexInput {
    /// The ring mesh's vertices.
    Ring,
    /// The vertex pre-pass's output (`render::placement`).
    Placed,
    /// Nothing: the stage pulls what it needs from storage buffers.
    None,
}

/// Where the clipmap's draws get their vertices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ClipmapVertices {
    /// Placed by the pre-pass (`vs_placed`).
    Placed,
    /// Placed by the vertex stage from the ring vertex buffer (`vs_main`).
    Ring,
    /// The wireframe overlay's: the vertex stage pulls the indices (`vs_main_wire`).
    Wire,
}

/// What the terrain pipelines are built from, kept to rebuild them when the look changes.
pub(super) struct PipelineParts {
    /// Kept to rebuild the pipelines when the level overlay is switched (`prepare`).
    pub(super) device: wgpu::Device,
    pub(super) module: wgpu::ShaderModule,
    pub(super) layout: wgpu::PipelineLayout,
    /// The vertex pre-pass's: the terrain group, none, its own (`render::placement`; None
    /// where the device cannot hold its buffer).
    pub(super) place_layout: Option<wgpu::PipelineLayout>,
    /// The clipmap's draws place their vertices themselves (`vs_main`) instead of reading the
    /// pre-pass's (`vs_placed`).
    pub(super) vertex_stage: bool,
    pub(super) color_format: wgpu::TextureFormat,
    pub(super) detail_on: bool,
    /// The terrain has water (its geometry rule and its shading).
    pub(super) water_on: bool,
    /// Imagery draped: the fragment reads the level imagery (`IMAGERY`).
    pub(super) imagery_on: bool,
    pub(super) form: u32,
    /// The level overlay (`Overlays::levels`) the pipelines were built with: its code is
    /// compiled in only while it is on (a CPU rasteriser runs a branch no fragment takes).
    pub(super) level_overlay: bool,
}

impl PipelineParts {
    /// The parts for `terrain` drawn with `settings` into `color_format`: the assembled
    /// terrain.wgsl, the pass's layout (group 0 and the planar methods' group) and, where the
    /// vertex pre-pass exists, its layout.
    pub(super) fn new(
        device: &wgpu::Device,
        terrain_layout: &wgpu::BindGroupLayout,
        planar_layout: &wgpu::BindGroupLayout,
        placement: Option<&Placement>,
        color_format: wgpu::TextureFormat,
        terrain: &Terrain,
        settings: &ClipmapSettings,
    ) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("terrain.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::TERRAIN).into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("terrain pipeline layout"),
            bind_group_layouts: &[Some(terrain_layout), Some(planar_layout)],
            immediate_size: 0,
        });
        let place_layout = placement.map(|p| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("vertex placement pipeline layout"),
                bind_group_layouts: &[Some(terrain_layout), None, Some(p.layout())],
                immediate_size: 0,
            })
        });
        Self {
            device: device.clone(),
            module,
            layout,
            vertex_stage: place_layout.is_none(),
            place_layout,
            color_format,
            detail_on: terrain.detail().is_some(),
            water_on: terrain.water_level_m().is_some(),
            imagery_on: terrain.imagery().is_some(),
            form: settings.transform.shader_code(),
            level_overlay: false,
        }
    }

    /// One pipeline of terrain.wgsl (planar.wgsl appended), its vertex stage fed by `input`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn pipeline(
        &self,
        device: &wgpu::Device,
        label: &str,
        vs: &str,
        fs: &str,
        constants: &[(&str, f64)],
        input: VertexInput,
        cull_mode: Option<wgpu::Face>,
    ) -> wgpu::RenderPipeline {
        let ring = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<RingVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &RING_VERTEX_ATTRIBUTES,
        })];
        let placed = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<PlacedVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &PLACED_VERTEX_ATTRIBUTES,
        })];
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &self.module,
                entry_point: Some(vs),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                buffers: match input {
                    VertexInput::Ring => &ring,
                    VertexInput::Placed => &placed,
                    VertexInput::None => &[],
                },
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                // Reversed-Z: nearer is larger.
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &self.module,
                entry_point: Some(fs),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                targets: &[Some(wgpu::ColorTargetState {
                    format: self.color_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// The look's and terrain's pipeline constants, with the clipmap's `MORPH` and `BLEND`.
    pub(super) fn constants(
        &self,
        look: LookSettings,
        morph: bool,
        blend: bool,
        cut: bool,
        wet: bool,
        wire: bool,
    ) -> Vec<(&'static str, f64)> {
        let flag = |on: bool| if on { 1.0 } else { 0.0 };
        vec![
            ("WET", flag(wet)),
            ("LEVEL_OVERLAY", flag(self.level_overlay)),
            ("WIRE_OVERLAY", flag(wire)),
            ("MORPH", flag(morph)),
            ("BLEND", flag(blend)),
            ("DETAIL", flag(self.detail_on)),
            ("TRANSFORM", self.form as f64),
            ("TEXTURES", flag(look.textures)),
            ("WATER", flag(self.water_on)),
            ("IMAGERY", flag(self.imagery_on)),
            ("SKY", flag(look.sky)),
            ("CUT", flag(cut)),
        ]
    }

    /// The clipmap's three variants (plain, blend band, morphing levels) with vertices from
    /// `source`; `cut` leaves a planar method's square out. With water, the indexed draws'
    /// also without the water's shading (the water cull's indirect draws).
    pub(super) fn clipmap_variants(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
        source: ClipmapVertices,
        cut: bool,
        shading: Shading,
    ) -> ClipmapPipelines {
        let (vs, input) = match source {
            ClipmapVertices::Placed => ("vs_placed", VertexInput::Placed),
            ClipmapVertices::Ring => ("vs_main", VertexInput::Ring),
            ClipmapVertices::Wire => ("vs_main_wire", VertexInput::None),
        };
        let wire = source == ClipmapVertices::Wire;
        let build = |wet: bool| {
            [(false, false), (false, true), (true, true)].map(|(morph, blend)| {
                let mut c = self.constants(look, morph, blend, cut, wet, wire);
                c.push(("FAR", if shading.far { 1.0 } else { 0.0 }));
                c.push(("BUMP", if shading.bump { 1.0 } else { 0.0 }));
                let label = format!(
                    "terrain {vs} (morph {morph}, blend {blend}, cut {cut}, wet {wet}, {shading:?})"
                );
                self.pipeline(
                    device,
                    &label,
                    vs,
                    "fs_main",
                    &c,
                    input,
                    Some(wgpu::Face::Back),
                )
            })
        };
        ClipmapPipelines {
            wet: build(true),
            dry: (self.water_on && !wire).then(|| build(false)),
        }
    }

    /// Where the clipmap's indexed draws take their vertices from.
    pub(super) fn clipmap_source(&self) -> ClipmapVertices {
        if self.vertex_stage {
            ClipmapVertices::Ring
        } else {
            ClipmapVertices::Placed
        }
    }

    /// The vertex pre-pass's pipelines, one per variant (plain, blend, morph): `cs_place` with
    /// the same constants as the draws' vertex stage.
    pub(super) fn place_pipelines(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
        layout: &wgpu::PipelineLayout,
    ) -> [wgpu::ComputePipeline; 3] {
        [(false, false), (false, true), (true, true)].map(|(morph, blend)| {
            let constants = self.constants(look, morph, blend, false, true, false);
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&format!("vertex placement (morph {morph}, blend {blend})")),
                layout: Some(layout),
                module: &self.module,
                entry_point: Some("cs_place"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                cache: None,
            })
        })
    }

    /// Geomipmapping's pipeline with vertex entry `vs` (`vs_geomip`, or `vs_geomip_wire` for
    /// the wireframe overlay): the clipmap's fragment stage, so the same shading wherever a
    /// fragment comes from. Skirts carry both windings; the patches are counter-clockwise.
    pub(super) fn geomip_pipeline(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
        geomorph: bool,
        vs: &str,
    ) -> wgpu::RenderPipeline {
        let mut c = self.constants(look, false, true, false, true, vs.ends_with("_wire"));
        c.push(("GEOMORPH", if geomorph { 1.0 } else { 0.0 }));
        self.pipeline(
            device,
            &format!("geomipmapping {vs}"),
            vs,
            "fs_main",
            &c,
            VertexInput::None,
            Some(wgpu::Face::Back),
        )
    }

    /// A projected-grid pipeline: vertex entry `vs` (`vs_projgrid`, `vs_projgrid_wire`),
    /// fragment `fs` (`fs_main`, or `fs_projgrid_ray`, which ray casts and writes depth).
    /// No culling: the grid's winding follows its parameters, not the screen.
    pub(super) fn grid_pipeline(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
        vs: &str,
        fs: &str,
    ) -> wgpu::RenderPipeline {
        let mut c = self.constants(look, false, true, false, true, vs.ends_with("_wire"));
        c.push(("GRID", 1.0));
        self.pipeline(
            device,
            &format!("projected grid {vs} {fs}"),
            vs,
            fs,
            &c,
            VertexInput::None,
            None,
        )
    }

    pub(super) fn build_grid(&self, device: &wgpu::Device, look: LookSettings) -> GridPipelines {
        GridPipelines {
            plain: self.grid_pipeline(device, look, "vs_projgrid", "fs_main"),
            ray_cast: self.grid_pipeline(device, look, "vs_projgrid", "fs_projgrid_ray"),
        }
    }

    /// The clipmap's variants cutting out a planar square, and geomipmapping's pipeline.
    pub(super) fn build_planar(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
        geomorph: bool,
    ) -> PlanarPipelines {
        PlanarPipelines {
            clipmap_cut: self.clipmap_variants(
                device,
                look,
                self.clipmap_source(),
                true,
                Shading::ALL,
            ),
            geomip: self.geomip_pipeline(device, look, geomorph, "vs_geomip"),
        }
    }

    /// The clipmap's pipelines for a frame that leaves some shading out ([`Shading`]).
    pub(super) fn build_shading(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
        shading: Shading,
    ) -> ClipmapPipelines {
        self.clipmap_variants(device, look, self.clipmap_source(), false, shading)
    }

    /// The wireframe overlay's pipelines: every method's, drawn without an index buffer.
    pub(super) fn build_wire(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
        geomorph: bool,
    ) -> WirePipelines {
        WirePipelines {
            clipmap: self.clipmap_variants(
                device,
                look,
                ClipmapVertices::Wire,
                false,
                Shading::ALL,
            ),
            clipmap_cut: self.clipmap_variants(
                device,
                look,
                ClipmapVertices::Wire,
                true,
                Shading::ALL,
            ),
            geomip: self.geomip_pipeline(device, look, geomorph, "vs_geomip_wire"),
            grid: None,
        }
    }

    /// The three terrain variants (plain, blend band, morphing levels), the pass-through and
    /// the vertex pre-pass's pipelines (None when the vertex stage places the vertices).
    /// Pipeline constants of terrain.wgsl: code a pipeline's draws cannot need is compiled
    /// out (a CPU rasteriser runs untaken branches), the look's parts that are off included.
    pub(super) fn build(
        &self,
        device: &wgpu::Device,
        look: LookSettings,
    ) -> (
        ClipmapPipelines,
        wgpu::RenderPipeline,
        Option<[wgpu::ComputePipeline; 3]>,
    ) {
        let pipelines =
            self.clipmap_variants(device, look, self.clipmap_source(), false, Shading::ALL);
        let passthrough = self.pipeline(
            device,
            "pass-through pipeline",
            "vs_passthrough",
            "fs_passthrough",
            &[],
            VertexInput::Ring,
            Some(wgpu::Face::Back),
        );
        let place = self
            .place_layout
            .as_ref()
            .filter(|_| !self.vertex_stage)
            .map(|layout| self.place_pipelines(device, look, layout));
        (pipelines, passthrough, place)
    }
}
