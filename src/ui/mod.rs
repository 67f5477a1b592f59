//! The interactive viewer: winit window + egui panel.
