//! The raw case-file schema, exactly as written in TOML (SI units). Unknown keys are refused.
//! Values whose meaning is checked after parsing keep their location (`Spanned`), so that every
//! error can point at the line and column. `docs/case-format.md` documents every key.

use serde::Deserialize;
use toml::Spanned;

pub type Real = f64;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCase {
    pub lattice: RawLattice,
    pub material: RawMaterial,
    pub geometry: RawGeometry,
    #[serde(default)]
    pub precrack: Vec<RawCrack>,
    #[serde(default)]
    pub boundary: Vec<RawBoundary>,
    #[serde(default)]
    pub initial: Vec<RawInitial>,
    pub solver: RawSolver,
    #[serde(default)]
    pub output: RawOutput,
    /// Contact settings (penalty stiffness, node radius, fragment contact).
    pub contact: Option<Spanned<RawContact>>,
    /// Rigid bodies: impactors, platens, supports.
    #[serde(default)]
    pub rigid: Vec<Spanned<RawRigid>>,
    /// Named isotropic materials that `[[phases]]` assign (the `[material]` table is the
    /// body's, which fills every node no phase takes).
    #[serde(default)]
    pub materials: std::collections::BTreeMap<String, Spanned<RawElastic>>,
    /// Phases: the nodes inside each shape are of the named material (a later phase overrides
    /// an earlier one).
    #[serde(default)]
    pub phases: Vec<Spanned<RawPhase>>,
    /// Interfaces: the springs between two named materials, with their own strength and
    /// stiffness factor.
    #[serde(default)]
    pub interfaces: Vec<Spanned<RawInterface>>,
    /// Random inclusions of a named material (each set one phase, before the `[[phases]]`).
    #[serde(default)]
    pub inclusions: Vec<Spanned<RawInclusions>>,
}

/// `[[inclusions]]`: a material of `[materials]`, a grading and a volume fraction.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawInclusions {
    pub material: Spanned<String>,
    pub fraction: Spanned<Real>,
    pub d_min: Spanned<Real>,
    pub d_max: Spanned<Real>,
    /// `"fuller"` (default) or `"uniform"`.
    pub grading: Option<Spanned<String>>,
    /// Fuller's exponent (default 0.5).
    pub fuller_exponent: Option<Spanned<Real>>,
    pub gap: Option<Spanned<Real>>,
    pub seed: Option<Spanned<i64>>,
}

/// `[[interfaces]]`: `between = ["a", "b"]`, and `critical_stretch` or `fracture_energy`,
/// and `stiffness_factor`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawInterface {
    pub between: Spanned<Vec<String>>,
    pub critical_stretch: Option<Spanned<Real>>,
    pub fracture_energy: Option<Spanned<Real>>,
    pub stiffness_factor: Option<Spanned<Real>>,
}

/// `weibull = { modulus = 5, seed = 1 }`: a Weibull scatter of a material's critical stretches
/// (the scale is its critical stretch).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawWeibull {
    pub modulus: Spanned<Real>,
    pub seed: Option<Spanned<i64>>,
}

/// An isotropic material of `[materials.NAME]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawElastic {
    pub youngs: Spanned<Real>,
    pub poisson: Spanned<Real>,
    pub density: Spanned<Real>,
    /// Its springs' own strength (else the body's `[material]` one's).
    pub critical_stretch: Option<Spanned<Real>>,
    pub fracture_energy: Option<Spanned<Real>>,
    pub weibull: Option<Spanned<RawWeibull>>,
}

/// One phase: a material of `[materials]` in a shape (`shape.sphere = {...}`, any shape of
/// `[[geometry.add]]`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPhase {
    pub material: Spanned<String>,
    pub shape: Spanned<RawShape>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawContact {
    pub stiffness_factor: Option<Spanned<Real>>,
    pub radius: Option<Spanned<Real>>,
    pub fragments: Option<bool>,
    pub fragment_distance: Option<Spanned<Real>>,
}

/// A rigid body: exactly one shape, placed at `position`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRigid {
    pub name: Option<String>,
    pub shape: Spanned<RawRigidShape>,
    pub position: Spanned<Vec<Real>>,
    #[serde(default)]
    pub velocity: Option<Spanned<Vec<Real>>>,
    /// "dynamic" (default) or "kinematic".
    pub motion: Option<Spanned<String>>,
    pub mass: Option<Spanned<Real>>,
    pub density: Option<Spanned<Real>>,
    pub friction: Option<Spanned<Real>>,
    /// Angular velocity (rad/s): `[wx, wy, wz]` in 3D, `[wz]` in 2D. Prescribed (constant, about
    /// the reference point) for a kinematic body, the initial one for a dynamic body.
    pub angular_velocity: Option<Spanned<Vec<Real>>>,
    /// A dynamic body turns under the contact torques (default true); false keeps it translating.
    pub rotates: Option<Spanned<bool>>,
    /// Move the body along its velocity until the nearest node is this far outside contact
    /// range (m): places impactors and platens independently of the resolution.
    pub start_gap: Option<Spanned<Real>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRigidShape {
    pub sphere: Option<RawRadius>,
    pub circle: Option<RawRadius>,
    /// Full edge lengths.
    #[serde(rename = "box")]
    pub bbox: Option<RawSize>,
    pub cylinder: Option<RawAxial>,
    pub capsule: Option<RawAxial>,
    pub halfspace: Option<RawHalfspace>,
    /// 2D: a convex polygon, vertices relative to the position.
    pub polygon: Option<RawPoints>,
    /// 3D: a closed triangle mesh, vertices relative to the position.
    pub mesh: Option<RawMesh>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRadius {
    pub radius: Spanned<Real>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSize {
    pub size: Spanned<Vec<Real>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawAxial {
    pub radius: Spanned<Real>,
    pub length: Spanned<Real>,
    pub axis: Spanned<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawHalfspace {
    /// Outward normal of the solid half-space.
    pub normal: Spanned<Vec<Real>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPoints {
    pub points: Spanned<Vec<Vec<Real>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLattice {
    pub kind: Spanned<String>,
    pub spacing: Spanned<Real>,
    pub thickness: Option<Spanned<Real>>,
    pub plane: Option<Spanned<String>>,
    /// Random lattices: "poisson" (default) or "jitter".
    pub sampler: Option<Spanned<String>>,
    /// Random lattices with the jittered grid: largest move per axis over the spacing (0.6).
    pub jitter: Option<Spanned<Real>>,
    /// Random lattices: the seed (default 1).
    pub seed: Option<Spanned<i64>>,
    /// The cubic lattice: lay it along this direction (the lattice axis nearest to it turned
    /// onto it), e.g. a fibre's.
    pub rotate_to: Option<Spanned<Vec<Real>>>,
    /// Regular lattices: weight springs and nodes by the share of the bulk's cells they stand
    /// for (default true where the lattice allows; false: every spring and node as in the bulk).
    pub cell_weights: Option<Spanned<bool>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMaterial {
    /// `"isotropic"` (default), `"transverse"` or `"orthotropic"`.
    pub kind: Option<Spanned<String>>,
    /// Isotropic: Young's modulus (Pa) and Poisson's ratio (required).
    pub youngs: Option<Spanned<Real>>,
    pub poisson: Option<Spanned<Real>>,
    /// Transverse: E_p, E_t (Pa), nu_p, nu_tp and G_t (Pa), and the fibre direction.
    pub youngs_plane: Option<Spanned<Real>>,
    pub youngs_fibre: Option<Spanned<Real>>,
    pub poisson_plane: Option<Spanned<Real>>,
    pub poisson_fibre: Option<Spanned<Real>>,
    pub shear_fibre: Option<Spanned<Real>>,
    pub fibre: Option<Spanned<Vec<Real>>>,
    /// Orthotropic: its material x and y axes in the body (`[[x], [y]]`; default the body's
    /// own, z = x cross y). Off the body's axes the lattice is laid along them.
    pub axes: Option<Spanned<Vec<Vec<Real>>>>,
    /// Orthotropic: E_x, E_y, E_z (Pa), nu_xy, nu_xz, nu_yz and G_yz, G_xz, G_xy (Pa), in the
    /// material axes.
    pub youngs_x: Option<Spanned<Real>>,
    pub youngs_y: Option<Spanned<Real>>,
    pub youngs_z: Option<Spanned<Real>>,
    pub poisson_xy: Option<Spanned<Real>>,
    pub poisson_xz: Option<Spanned<Real>>,
    pub poisson_yz: Option<Spanned<Real>>,
    pub shear_yz: Option<Spanned<Real>>,
    pub shear_xz: Option<Spanned<Real>>,
    pub shear_xy: Option<Spanned<Real>>,
    pub density: Spanned<Real>,
    pub fracture_energy: Option<Spanned<Real>>,
    pub critical_stretch: Option<Spanned<Real>>,
    /// Transverse materials: the critical stretch of springs along the fibre (`critical_stretch`
    /// is then the one across it).
    pub critical_stretch_fibre: Option<Spanned<Real>>,
    /// `"stretch"` (default), `"energy"` or `"softening"`.
    pub criterion: Option<Spanned<String>>,
    /// Softening springs: `"linear"` (default) or `"bilinear"`.
    pub softening: Option<Spanned<String>>,
    /// Softening springs: tensile strength f_t (Pa), with `fracture_energy`.
    pub tensile_strength: Option<Spanned<Real>>,
    /// Softening springs: characteristic length `E G_f / f_t^2` (m), instead of the strength.
    pub characteristic_length: Option<Spanned<Real>>,
    /// Softening springs given directly: the peak stretch ...
    pub peak_stretch: Option<Spanned<Real>>,
    /// ... and the final stretch, where the spring is broken.
    pub final_stretch: Option<Spanned<Real>>,
    /// The material's name in a body of several materials (default `"material"`).
    pub name: Option<Spanned<String>>,
    /// A Weibull scatter of the springs' critical stretches.
    pub weibull: Option<Spanned<RawWeibull>>,
    /// A lognormal random field of Young's modulus.
    pub stiffness_field: Option<Spanned<RawField>>,
}

/// `stiffness_field = { cov = 0.2, correlation_length = 5e-3, seed = 1 }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawField {
    pub cov: Spanned<Real>,
    pub correlation_length: Spanned<Real>,
    pub seed: Option<Spanned<i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBox {
    pub min: Spanned<Vec<Real>>,
    pub max: Spanned<Vec<Real>>,
}

/// The body: `box = {...}`, or the union of `[[geometry.add]]` shapes; minus the union of
/// `[[geometry.subtract]]` shapes (holes, notches) in either case.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawGeometry {
    #[serde(rename = "box")]
    pub bbox: Option<RawBox>,
    #[serde(default)]
    pub add: Vec<Spanned<RawShape>>,
    #[serde(default)]
    pub subtract: Vec<Spanned<RawShape>>,
}

/// One primitive (exactly one key).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawShape {
    #[serde(rename = "box")]
    pub bbox: Option<RawBox>,
    /// A ball (3D) or disk (2D).
    pub sphere: Option<RawBall>,
    /// Same as `sphere`, the name for 2D bodies.
    pub circle: Option<RawBall>,
    pub cylinder: Option<RawCylinder>,
    pub polygon: Option<RawPolygon>,
    /// A closed triangle mesh (3D): `mesh = { file = "part.stl", scale = 1e-3 }`.
    pub mesh: Option<RawMesh>,
}

/// A closed triangle mesh file (STL or OBJ), relative to the case file; coordinates times
/// `scale` (default 1: metres).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMesh {
    pub file: Spanned<String>,
    pub scale: Option<Spanned<Real>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBall {
    pub center: Spanned<Vec<Real>>,
    pub radius: Spanned<Real>,
}

/// A circular cylinder along a coordinate axis, centred at `center`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCylinder {
    pub center: Spanned<Vec<Real>>,
    pub axis: Spanned<String>,
    pub radius: Spanned<Real>,
    pub length: Spanned<Real>,
}

/// A polygon in the x-y plane (vertices in order); in 3D extruded between `z = [z0, z1]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPolygon {
    pub points: Spanned<Vec<Vec<Real>>>,
    pub z: Option<Spanned<Vec<Real>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCrack {
    pub segment: Option<Spanned<Vec<Vec<Real>>>>,
    pub polygon: Option<Spanned<Vec<Vec<Real>>>>,
}

/// A node set: the nodes inside a box, within `tolerance` of a plane `axis = at`, or on a face
/// of the body (`"x-"`, `"x+"`, `"y-"`, ...: the nodes at its extreme along that axis, whatever
/// the resolution).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRegion {
    #[serde(rename = "box")]
    pub bbox: Option<RawBox>,
    pub plane: Option<RawPlane>,
    pub face: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlane {
    pub axis: Spanned<String>,
    pub at: Spanned<Real>,
    pub tolerance: Option<Spanned<Real>>,
}

/// A function of time: a constant, a ramp from 0 to `value` over `ramp` seconds (`smooth`:
/// half-cosine), or a table of `[t, value]` points.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMotion {
    pub axis: Spanned<String>,
    pub value: Option<Spanned<Real>>,
    pub ramp: Option<Spanned<Real>>,
    #[serde(default)]
    pub smooth: bool,
    pub table: Option<Spanned<Vec<Vec<Real>>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBoundary {
    pub region: Spanned<RawRegion>,
    #[serde(default)]
    pub fixed: Vec<Spanned<String>>,
    #[serde(default)]
    pub velocity: Vec<RawMotion>,
    #[serde(default)]
    pub displacement: Vec<RawMotion>,
    #[serde(default)]
    pub traction: Vec<RawTraction>,
    #[serde(default)]
    pub no_fail: bool,
}

/// A traction (Pa) on the region's nodes, which lie on a face with outward normal along
/// `normal`: each node carries the traction times its share of the face.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTraction {
    pub value: Spanned<Vec<Real>>,
    pub normal: Spanned<String>,
    pub ramp: Option<Spanned<Real>>,
    #[serde(default)]
    pub smooth: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawInitial {
    pub region: Option<Spanned<RawRegion>>,
    pub velocity: Spanned<Vec<Real>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSolver {
    /// `"explicit"` (default) or `"quasi-static"`.
    #[serde(rename = "type")]
    pub kind: Option<Spanned<String>>,
    /// Load steps of a quasi-static solve (default 20).
    pub steps: Option<Spanned<i64>>,
    pub end_time: Spanned<Real>,
    pub dt: Option<Spanned<Real>>,
    pub safety: Option<Spanned<Real>>,
    pub damping: Option<Spanned<Real>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawOutput {
    pub every: Option<Spanned<Real>>,
    pub checkpoint_every: Option<Spanned<Real>>,
    /// Time between reaction records (s); default: at frames.
    pub reactions_every: Option<Spanned<Real>>,
    #[serde(default)]
    pub springs: bool,
    /// Output formats: `"vtk"` (default) and/or `"hdf5"`.
    pub format: Option<Spanned<Vec<String>>>,
    /// The point fields frames carry (default: all; `node_id` always).
    pub fields: Option<Spanned<Vec<String>>>,
}
