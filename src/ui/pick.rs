//! What lies under the cursor, live (issue 38's pick): the f64 reference ray caster over the
//! terrain function (detail and water included, the surface that is drawn and measured), on a
//! thread of its own so the window never waits for it; a remote DEM's tiles it needs are
//! fetched there. Requests are coalesced: a cursor that moves while a cast runs gets the
//! answer for where it is now, not for every place it passed.

use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};

use glam::DVec3;

use crate::geo::camera::Camera;
use crate::measure::{ProbeHit, RayCaster, RayHit};
use crate::terrain::Terrain;

/// One pixel of one view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PickRequest {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub x: u32,
    pub y: u32,
}

/// The answer: the surface point (None for sky) and where it is in the world frame, metres
/// from the planet's centre (for the fly-to and measure).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Picked {
    pub request: PickRequest,
    pub hit: Option<(ProbeHit, DVec3)>,
}

/// Casts one request on `terrain`.
pub fn pick(terrain: &Terrain, r: &PickRequest) -> Picked {
    let caster = RayCaster::new(terrain, &r.camera, r.width, r.height);
    let hit = match caster.cast_pixel(r.x, r.y) {
        RayHit::Sky => None,
        RayHit::Terrain {
            distance_m,
            point_view_m,
        } => {
            let world = r.camera.view_frame().world_from_view * point_view_m;
            let probe = crate::measure::probe::hit_at_world(terrain, world, distance_m);
            Some((probe, world))
        }
    };
    Picked { request: *r, hit }
}

/// The worker thread and the latest answer.
pub struct Picker {
    requests: Sender<(PickRequest, Terrain)>,
    answers: Receiver<Picked>,
    /// The last request sent (not sent again while it stands).
    asked: Option<PickRequest>,
    latest: Option<Picked>,
}

impl Picker {
    pub fn new() -> Self {
        let (requests, inbox) = channel::<(PickRequest, Terrain)>();
        let (outbox, answers) = channel();
        std::thread::Builder::new()
            .name("globe pick".into())
            .spawn(move || {
                while let Ok(mut next) = inbox.recv() {
                    // Only the newest request matters.
                    loop {
                        match inbox.try_recv() {
                            Ok(newer) => next = newer,
                            Err(TryRecvError::Empty) => break,
                            Err(TryRecvError::Disconnected) => return,
                        }
                    }
                    if outbox.send(pick(&next.1, &next.0)).is_err() {
                        return;
                    }
                }
            })
            .expect("the pick thread starts");
        Self {
            requests,
            answers,
            asked: None,
            latest: None,
        }
    }

    /// Asks for `request` over `terrain` unless it is the one asked last.
    pub fn ask(&mut self, request: PickRequest, terrain: &Terrain) {
        if self.asked == Some(request) {
            return;
        }
        self.asked = Some(request);
        // A closed channel (the thread ended) leaves the last answer standing.
        let _ = self.requests.send((request, terrain.clone()));
    }

    /// Forgets the cursor (it left the terrain's part of the window).
    pub fn clear(&mut self) {
        self.asked = None;
        self.latest = None;
    }

    /// Takes what the thread answered; the newest answer, if any.
    pub fn poll(&mut self) -> Option<&Picked> {
        while let Ok(answer) = self.answers.try_recv() {
            // An answer to a request since replaced still shows until the newer one comes.
            if self.asked.is_some() {
                self.latest = Some(answer);
            }
        }
        self.latest.as_ref()
    }

    /// Whether the newest answer is for the request asked last.
    pub fn is_current(&self) -> bool {
        self.latest.is_some_and(|l| Some(l.request) == self.asked)
    }
}

impl Default for Picker {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thread answers the newest request, with the probe's own answer for it.
    #[test]
    fn the_thread_answers_the_newest_request() {
        let terrain = Terrain::analytic_earth();
        let mut picker = Picker::new();
        let down = |lat_deg: f64| Camera {
            lat_deg,
            lon_deg: 10.0,
            altitude_m: 20_000.0,
            heading_deg: 0.0,
            pitch_deg: -90.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        };
        let request = |lat| PickRequest {
            camera: down(lat),
            width: 65,
            height: 65,
            x: 32,
            y: 32,
        };
        for lat in [10.0, 20.0, 30.0] {
            picker.ask(request(lat), &terrain);
        }
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        while !picker.is_current() {
            picker.poll();
            assert!(std::time::Instant::now() < deadline, "no answer in 60 s");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let got = *picker.poll().unwrap();
        assert_eq!(got, pick(&terrain, &request(30.0)));
        let (hit, world) = got.hit.unwrap();
        assert!((hit.lat_deg - 30.0).abs() < 1e-7, "{hit:?}");
        let r = terrain.radius_m() + hit.height_m;
        assert!(
            (world.length() - r).abs() < 0.01,
            "{} vs {r}",
            world.length()
        );
        picker.clear();
        assert!(picker.poll().is_none());
    }
}
