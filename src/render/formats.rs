//! The formats of the frame's targets, named once for every pass that draws into them (the
//! terrain, the sky, the close-up passes) and for whoever creates the targets (the offscreen
//! frame, the window's surface).

/// Reversed-Z f32 depth (`geo::projection::clip_from_camera`): with a float buffer the depth
/// precision is nearly constant in distance, from a millimetre to the whole planet.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Colour of offscreen frames (sRGB, so PNGs look as they do in the window).
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
