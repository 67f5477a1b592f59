//! Mouse and keyboard state between window events, and what the held keys mean for flying.

use std::collections::HashSet;

use winit::dpi::PhysicalPosition;
use winit::event::MouseButton;
use winit::keyboard::{KeyCode, ModifiersState};

use super::controls::FlyInput;

/// What a mouse drag does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Drag {
    Look,
    Pan,
}

/// Mouse and keyboard state between events.
#[derive(Default)]
pub(super) struct Input {
    pub(super) keys: HashSet<KeyCode>,
    pub(super) modifiers: ModifiersState,
    pub(super) cursor: Option<PhysicalPosition<f64>>,
    pub(super) drag: Option<(MouseButton, Drag)>,
}

impl Input {
    pub(super) fn release_all(&mut self) {
        self.keys.clear();
        self.drag = None;
    }

    pub(super) fn fly_input(&self) -> FlyInput {
        let axis = |plus: KeyCode, minus: KeyCode| {
            f64::from(u8::from(self.keys.contains(&plus)))
                - f64::from(u8::from(self.keys.contains(&minus)))
        };
        FlyInput {
            forward: axis(KeyCode::KeyW, KeyCode::KeyS),
            right: axis(KeyCode::KeyD, KeyCode::KeyA),
            up: axis(KeyCode::KeyE, KeyCode::KeyQ),
            turn: axis(KeyCode::ArrowRight, KeyCode::ArrowLeft),
            pitch: axis(KeyCode::ArrowUp, KeyCode::ArrowDown),
            boost: self.modifiers.shift_key(),
        }
    }
}
