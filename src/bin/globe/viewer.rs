//! `globe` with no command: the viewer window.

use std::process::ExitCode;

use anyhow::bail;
use clap::Args;
use globe::scenes::CameraSpec;

use crate::args::*;
use crate::scenes::*;

#[derive(Args)]
pub struct ViewerArgs {
    /// Bookmark to open the viewer at (see `globe scenes`).
    #[arg(long, default_value = "space", conflicts_with = "camera")]
    pub scene: String,
    /// Open the viewer at this view instead of a bookmark. Same form as `globe render
    /// --camera`; the panel's "go to" field takes it too.
    #[arg(long, value_name = "VIEW", allow_hyphen_values = true)]
    pub camera: Option<CameraSpec>,
    /// Replay a recorded camera path (JSON, as the R key writes it) from the start.
    #[arg(long, value_name = "FILE.json")]
    pub path: Option<std::path::PathBuf>,
    /// Debug overlay to start with.
    #[arg(long)]
    pub overlay: Option<Overlay>,
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[command(flatten)]
    pub dem: DemArgs,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub lod: LodArgs,
    #[command(flatten)]
    pub stream: StreamArgs,
}

pub fn viewer(args: &ViewerArgs) -> anyhow::Result<ExitCode> {
    let (_, start) = chosen_view(&args.scene, args.camera)?;
    if args.overlay == Some(Overlay::Error) {
        bail!(
            "--overlay error is for `globe render`; in the viewer press the panel's \
             \"error overlay (ρ)\" button (it measures the view on the CPU, on demand)"
        );
    }
    let options = globe::ui::ViewerOptions {
        start,
        settings: args.mesh.settings()?,
        overlay_levels: args.overlay == Some(Overlay::Levels),
        overlay_wireframe: args.overlay == Some(Overlay::Wireframe),
        terrain: args.dem.open()?,
        look: args.look.settings(),
        lod: args.lod.settings()?,
        stream: args.stream.settings()?,
        replay: match &args.path {
            Some(file) => Some(globe::scenes::path::CameraPath::load(file)?),
            None => None,
        },
    };
    match globe::ui::run(options) {
        Ok(()) => Ok(ExitCode::SUCCESS),
        Err(globe::ui::UiError::NoDisplay(why)) => {
            eprintln!("globe: {why}");
            Ok(ExitCode::from(2))
        }
        Err(e) => Err(e.into()),
    }
}
