//! The terrain pass's draw calls: the clipmap's ranges by (cut, variant) and the water cull's
//! indirect draws, the close-up method's patches or grid, the wireframe overlay, then the sky.

use super::pipelines::WirePipelines;
use super::{FrameInfo, TerrainRenderer};
use crate::clipmap::draw_list::Variant;
use crate::render::planar::{GridDraw, PlanarDraw};
use crate::render::water_cull::WaterCull;

impl TerrainRenderer {
    /// Records a whole terrain pass: colour cleared to the sky, depth cleared to 0 (reversed-Z),
    /// then the draw calls of `info`. `depth_store` keeps the depth for readback or discards it;
    /// `timestamps` times the pass on the GPU (from the work `prepare` recorded after the fill
    /// when it started the timing there).
    pub fn encode_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        info: &FrameInfo,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        depth_store: wgpu::StoreOp,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        // With the sky on, its pass shades every pixel the terrain leaves, black beyond the
        // shell: the clear colour shows only outside `sky_ring`, where the pass would be black.
        let [r, g, b] = if self.look.sky && !self.switches.use_passthrough {
            [0.0; 3]
        } else {
            info.sky_linear
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("terrain"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: depth_store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: timestamps.map(|t| wgpu::RenderPassTimestampWrites {
                beginning_of_pass_write_index: t
                    .beginning_of_pass_write_index
                    .filter(|_| !self.timing_started),
                ..t
            }),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        self.draw(&mut pass, info);
    }

    /// Records the terrain draw calls of `info` into `pass`.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, info: &FrameInfo) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_bind_group(1, self.planar.bind_group(), &[]);
        pass.set_vertex_buffer(
            0,
            match (&self.placement, self.placed_drawn()) {
                (Some(p), true) => p.vertex_buffer().slice(..),
                _ => self.buffers.vertices.slice(..),
            },
        );
        pass.set_index_buffer(self.buffers.indices.slice(..), wgpu::IndexFormat::Uint32);
        let mut current = None;
        let wire = self
            .wire_pipelines
            .as_ref()
            .filter(|_| self.overlays.wireframe && !self.switches.use_passthrough);
        // The projected grid draws alone.
        if let Some(grid) = info.planar.as_ref().and_then(|p| p.grid.as_ref()) {
            self.draw_grid(pass, grid, wire);
            if self.look.sky && !self.switches.use_passthrough {
                self.look_resources.draw_sky(pass, info.sky_ring);
            }
            return;
        }
        // With a planar method the clipmap leaves its square out.
        let planar = match (&info.planar, &self.planar_pipelines) {
            (Some(draw), Some(pipelines)) if !self.switches.use_passthrough => {
                Some((draw, pipelines))
            }
            _ => None,
        };
        let shaded = (self.shading_pipelines.iter())
            .find(|(s, _)| *s == info.shading)
            .map(|(_, p)| p);
        let uncut = match (wire, shaded) {
            (Some(w), _) => &w.clipmap,
            (None, Some(p)) => p,
            (None, None) => &self.pipelines,
        };
        let cull = self
            .passes
            .water_cull
            .as_ref()
            .filter(|_| !self.switches.use_passthrough && !self.switches.ignore_water_cull);
        let cut = match (wire, planar) {
            (Some(w), Some(_)) => &w.clipmap_cut,
            (None, Some((_, p))) => &p.clipmap_cut,
            (_, None) => uncut,
        };
        for (i, (range, &variant)) in info.draw.ranges.iter().zip(&info.draw.variants).enumerate() {
            if range.is_empty() {
                continue;
            }
            // The pipeline set by (cut, variant): a range of the cut never reuses an uncut one.
            let in_cut = i >= info.draw.first_cut;
            let clipmap = if in_cut { cut } else { uncut };
            let v = match variant {
                Variant::Plain => 0,
                Variant::Blend => 1,
                Variant::Morph => 2,
            };
            if let (Some(cull), Some(dry)) = (cull, &clipmap.dry) {
                // Twice, each draw with the instance the water cull gave it or none.
                pass.set_pipeline(&dry[v]);
                pass.draw_indexed_indirect(cull.args(), WaterCull::offset(i, false));
                pass.set_pipeline(&clipmap.wet[v]);
                pass.draw_indexed_indirect(cull.args(), WaterCull::offset(i, true));
                current = Some((in_cut, variant));
                continue;
            }
            if current != Some((in_cut, variant)) {
                pass.set_pipeline(if self.switches.use_passthrough {
                    &self.passthrough
                } else {
                    &clipmap.wet[v]
                });
                current = Some((in_cut, variant));
            }
            if wire.is_some() {
                pass.draw(range.clone(), 0..1);
            } else {
                pass.draw_indexed(range.clone(), 0, 0..1);
            }
        }
        if let Some((draw, pipelines)) = planar {
            match wire {
                Some(w) => pass.set_pipeline(&w.geomip),
                None => pass.set_pipeline(&pipelines.geomip),
            }
            self.draw_patches(pass, draw, wire.is_some());
        }
        if self.look.sky && !self.switches.use_passthrough {
            self.look_resources.draw_sky(pass, info.sky_ring);
        }
    }

    /// The projected grid's draw (its cells above γ ray cast when the plan says so).
    fn draw_grid(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        grid: &GridDraw,
        wire: Option<&WirePipelines>,
    ) {
        let Some(pipelines) = &self.grid_pipelines else {
            return;
        };
        if grid.indices.is_empty() || self.switches.use_passthrough {
            return;
        }
        match wire.and_then(|w| w.grid.as_ref()) {
            Some(w) => {
                pass.set_pipeline(if grid.ray_cast { &w.ray_cast } else { &w.plain });
                pass.draw(grid.indices.clone(), 0..1);
            }
            None => {
                pass.set_pipeline(if grid.ray_cast {
                    &pipelines.ray_cast
                } else {
                    &pipelines.plain
                });
                pass.set_index_buffer(
                    self.planar.grid_index_buffer().slice(..),
                    wgpu::IndexFormat::Uint32,
                );
                pass.draw_indexed(grid.indices.clone(), 0, 0..1);
            }
        }
    }

    /// Geomipmapping's patches, each its index range with its patch as the instance (the
    /// pipeline is set).
    fn draw_patches(&self, pass: &mut wgpu::RenderPass<'_>, draw: &PlanarDraw, wire: bool) {
        pass.set_index_buffer(
            self.planar.index_buffer().slice(..),
            wgpu::IndexFormat::Uint32,
        );
        for (range, patch) in &draw.draws {
            if wire {
                pass.draw(range.clone(), *patch..*patch + 1);
            } else {
                pass.draw_indexed(range.clone(), 0, *patch..*patch + 1);
            }
        }
    }
}
