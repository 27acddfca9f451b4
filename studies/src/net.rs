//! The system in space at one instant: every cable's points and element forces, the cabin, the
//! Stewart platform with its legs, the feed point and the towers — what the figures of the net
//! ([`crate::view3d`]) and the VTK files are made of, and what a run hands to
//! a [`NetSink`] at its samples.
//!
//! The cable crate owns the node geometry ([`cable::system::System::cable_points`],
//! `element_forces`, `point_motion`); this module adds the rigid bodies, placed from the cabin's
//! pose and the platform's pose relative to the cabin.

use cable::statics::Equilibrium;
use cable::system::{Config, Support, System};
use feedcore::scene::{LEGS, StewartMode, ValidScene};
use feedcore::{Quat, Vec3};

/// What does not move: the towers, the body-frame points of the cabin and the platform, the
/// size of the net.
#[derive(Clone, Debug)]
pub struct Layout {
    pub cables: usize,
    pub elements: usize,
    /// Tower tops, world frame.
    pub anchors: Vec<Vec3>,
    /// Cable attachment points, cabin frame.
    pub attachments: Vec<Vec3>,
    /// The platform (absent with `analyses.stewart = "absent"`): Hooke joints on the cabin (cabin
    /// frame), spherical joints (platform frame), the feed point (platform frame).
    pub platform: Option<PlatformLayout>,
}

/// The Stewart platform's points in its own frames.
#[derive(Clone, Debug)]
pub struct PlatformLayout {
    pub base_joints: [Vec3; LEGS],
    pub platform_joints: [Vec3; LEGS],
    pub feed_point: Vec3,
    /// The platform centre at the start, cabin frame.
    pub start_center: Vec3,
}

impl Layout {
    pub fn of(scene: &ValidScene) -> Layout {
        let platform = (scene.analyses.stewart != StewartMode::Absent).then(|| {
            let g = scene.stewart_geometry();
            PlatformLayout {
                base_joints: g.base_joints,
                platform_joints: g.platform_joints,
                feed_point: Vec3::from(scene.control.as_ref().map_or([0.0; 3], |c| c.feed_point_m)),
                start_center: g.start_center,
            }
        });
        Layout {
            cables: scene.cable_count(),
            elements: scene.cables.elements,
            anchors: scene.anchors(),
            attachments: scene.attachments_body(),
            platform,
        }
    }

    /// Points of one cable (anchor to attachment point).
    pub fn points_per_cable(&self) -> usize {
        self.elements + 1
    }

    /// The order of the attachment points around the cabin (by azimuth in the cabin frame),
    /// which outlines it.
    pub fn cabin_outline(&self) -> Vec<usize> {
        by_azimuth(&self.attachments)
    }
}

/// Indices of `points` sorted by their azimuth about the z axis.
pub fn by_azimuth(points: &[Vec3]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].y.atan2(points[a].x).total_cmp(&points[b].y.atan2(points[b].x)));
    order
}

/// The system at one instant.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    pub time: f64,
    /// Every cable's points, cable by cable from the anchor ([`Layout::points_per_cable`] each).
    pub points: Vec<Vec3>,
    /// Every element's axial force, N, cable by cable from the anchor (zero when slack).
    pub tensions: Vec<f64>,
    /// The cabin centre point and orientation (body to world).
    pub cabin: (Vec3, Quat),
    /// The platform's centre (cabin frame) and orientation relative to the cabin.
    pub platform: (Vec3, Quat),
    /// Actuator forces (tension positive), N, where the method computes them.
    pub leg_forces: Option<[f64; LEGS]>,
}

/// The platform's points in the world at one instant.
#[derive(Clone, Copy, Debug)]
pub struct PlacedPlatform {
    pub base_joints: [Vec3; LEGS],
    pub platform_joints: [Vec3; LEGS],
    pub center: Vec3,
    pub feed: Vec3,
}

impl Frame {
    /// The cable–cabin part from a system and its configuration (time and platform as given).
    pub fn fill_cables(&mut self, system: &System, cfg: &Config) {
        self.points.clear();
        self.tensions.clear();
        system.cable_points(cfg, &mut self.points);
        system.element_forces(cfg, &mut self.tensions);
        self.cabin = (cfg.position, cfg.orientation);
    }

    /// A static equilibrium with the platform at its start (at rest, time 0).
    pub fn of_equilibrium(layout: &Layout, system: &System, eq: &Equilibrium) -> Frame {
        let mut f = Frame::default();
        f.fill_cables(system, &system.config_from(eq));
        f.platform = (layout.platform.as_ref().map_or(Vec3::zeros(), |p| p.start_center), Quat::identity());
        f
    }

    /// A world point of the cabin given in the cabin frame.
    pub fn on_cabin(&self, body: &Vec3) -> Vec3 {
        self.cabin.0 + self.cabin.1 * body
    }

    /// The platform's joints, centre and feed point in the world.
    pub fn place(&self, p: &PlatformLayout) -> PlacedPlatform {
        let (center, turn) = self.platform;
        let on_platform = |x: &Vec3| self.on_cabin(&(center + turn * x));
        PlacedPlatform {
            base_joints: p.base_joints.map(|b| self.on_cabin(&b)),
            platform_joints: p.platform_joints.map(|j| on_platform(&j)),
            center: self.on_cabin(&center),
            feed: on_platform(&p.feed_point),
        }
    }
}

/// The system of a scene's static equilibrium (the platform locked at its start, as the statics
/// has it) and its frame.
pub fn equilibrium_frame(scene: &ValidScene, layout: &Layout, eq: &Equilibrium) -> (System, Frame) {
    let system = System::new(cable::net::CableNet::from_scene(scene), eq.lengths(), true, Support::Free);
    let frame = Frame::of_equilibrium(layout, &system, eq);
    (system, frame)
}

/// Where a run hands its net: every `every`-th sample from the start.
pub trait NetSink {
    /// The net at one sample.
    fn frame(&mut self, layout: &Layout, frame: &Frame) -> std::io::Result<()>;
}

/// Keeps every cable point of every frame handed to it (the Python package's `Result.net()`).
#[derive(Clone, Debug, Default)]
pub struct NetRecord {
    pub times: Vec<f64>,
    /// Per frame, every cable's points (x, y, z), cable by cable from the anchor.
    pub positions: Vec<f64>,
    pub cables: usize,
    pub points_per_cable: usize,
}

impl NetSink for NetRecord {
    fn frame(&mut self, layout: &Layout, frame: &Frame) -> std::io::Result<()> {
        self.cables = layout.cables;
        self.points_per_cable = layout.points_per_cable();
        self.times.push(frame.time);
        self.positions.extend(frame.points.iter().flat_map(|p| [p.x, p.y, p.z]));
        Ok(())
    }
}

/// The largest motion of a cable point (the attachment points carry the cabin's) for a
/// velocity-level vector `du` at `cfg`.
pub fn largest_motion(system: &System, cfg: &Config, du: &[f64]) -> f64 {
    let mut motion = Vec::new();
    system.point_motion(cfg, du, &mut motion);
    motion.iter().map(|m| m.norm()).fold(0.0, f64::max)
}

/// The cable points of `rest` moved along `du` times `s` (a mode shape drawn over its
/// equilibrium), by [`System::point_motion`]: linear, as a mode shape is.
pub fn moved_points(rest: &Frame, system: &System, cfg: &Config, du: &[f64], s: f64) -> Vec<Vec3> {
    let mut motion = Vec::new();
    system.point_motion(cfg, du, &mut motion);
    rest.points.iter().zip(&motion).map(|(p, m)| p + m * s).collect()
}

/// The cabin's part (δr, δθ) of a velocity-level vector of `system`.
pub fn cabin_motion(system: &System, du: &[f64]) -> (Vec3, Vec3) {
    let c0 = system.cabin_offset();
    (Vec3::new(du[c0], du[c0 + 1], du[c0 + 2]), Vec3::new(du[c0 + 3], du[c0 + 4], du[c0 + 5]))
}
