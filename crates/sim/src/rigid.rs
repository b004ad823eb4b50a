//! Contact set-up: the contact options and the rigid bodies as a user wrote them, checked
//! against the built body and placed. Case files (`[contact]`, `[[rigid]]`) and the Python
//! builder both come through here, so their checks and messages are the same; an error names
//! the key (`contact.fragment_distance`, `rigid[2].position`, ...) for the caller to locate.

use hooke_contact::{Contact, ContactOptions, RigidBody};
use hooke_core::{Body, Real};

use crate::builder::BuildError;

/// Contact options as written: `None` takes the lattice's default (`c = 0.1`, node radius
/// `a/2`, fragment contact below 0.8 of the shortest spring).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactSpec {
    /// `c` in `k = c m / dt^2`, in (0, 1].
    pub stiffness_factor: Option<Real>,
    /// Contact radius of a node (m).
    pub radius: Option<Real>,
    /// `Some(false)` turns fragment contact off.
    pub fragments: Option<bool>,
    /// Fragment contact distance (m), below 0.95 of the shortest spring.
    pub fragment_distance: Option<Real>,
}

/// A rigid body as written, and how to place it.
#[derive(Clone, Debug)]
pub struct RigidSpec {
    pub body: RigidBody,
    /// Move the body along its velocity until the nearest node is this far outside its
    /// contact range (m): places impactors independently of the resolution.
    pub start_gap: Option<Real>,
}

impl From<RigidBody> for RigidSpec {
    fn from(body: RigidBody) -> Self {
        RigidSpec {
            body,
            start_gap: None,
        }
    }
}

fn positive(x: Real, key: &str, unit: &str) -> Result<Real, BuildError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(BuildError::new(
            key,
            format!("{x}: give a positive value in {unit}"),
        ))
    }
}

/// The options for `body`: its defaults overridden by `spec`, checked.
/// A node nearest to a rigid body: its index in the body, its gap to the node's contact range
/// (m; negative: inside it) and its position (m).
pub(crate) type Nearest = (usize, Real, [Real; 3]);

/// What contact's set-up asks of the whole body. One process answers from the body
/// ([`Across::whole`]); processes that each hold a piece of it answer together
/// (`builder::parts`).
pub(crate) struct Across<'a> {
    /// The body's shortest spring (m).
    pub shortest: Real,
    /// Nodes of the body.
    pub nodes: usize,
    /// The nodes of this process's body whose nearness is asked (its own, on a piece).
    pub scan: std::ops::Range<usize>,
    /// The body's index of a node of `scan`.
    pub global: &'a dyn Fn(usize) -> usize,
    /// The nearest of every process's nearest node `(body index, gap, position)`, the lowest
    /// index among equal gaps (as one process's scan finds it).
    pub nearest: &'a dyn Fn(Option<Nearest>) -> Option<Nearest>,
}

impl Across<'_> {
    /// The answers of one process that holds the whole body.
    fn whole(body: &Body) -> Across<'static> {
        Across {
            shortest: body.lattice.shortest(),
            nodes: body.nodes(),
            scan: 0..body.nodes(),
            global: &|i| i,
            nearest: &|n| n,
        }
    }
}

pub fn contact_options(body: &Body, spec: &ContactSpec) -> Result<ContactOptions, BuildError> {
    contact_options_across(body, spec, &Across::whole(body))
}

fn contact_options_across(
    body: &Body,
    spec: &ContactSpec,
    whole: &Across,
) -> Result<ContactOptions, BuildError> {
    let mut o = ContactOptions::for_lattice(body.lattice.spacing, whole.shortest);
    if let Some(x) = spec.stiffness_factor {
        if !(x > 0.0 && x <= 1.0) {
            return Err(BuildError::new(
                "contact.stiffness_factor",
                format!(
                    "{x}: give 0 < c <= 1 (k = c m / dt^2; the default 0.1 keeps the step stable)"
                ),
            ));
        }
        o.stiffness_factor = x;
    }
    if let Some(r) = spec.radius {
        o.radius = positive(r, "contact.radius", "m")?;
    }
    if spec.fragments == Some(false) {
        o.fragment_distance = None;
    }
    if let Some(d) = spec.fragment_distance {
        let d = positive(d, "contact.fragment_distance", "m")?;
        let shortest = whole.shortest;
        if d >= 0.95 * shortest {
            return Err(BuildError::new(
                "contact.fragment_distance",
                format!("{d:e} m: keep it below 0.95 x the shortest spring ({shortest:e} m), or springs that break would start in contact"),
            ));
        }
        if spec.fragments == Some(false) {
            return Err(BuildError::new(
                "contact.fragment_distance",
                "fragments = false turns fragment contact off; remove one of the two",
            ));
        }
        o.fragment_distance = Some(d);
    }
    Ok(o)
}

/// The node nearest to the body's surface within `limit` of its bounds: its index in the
/// body, its gap to the node's contact range (m; negative: inside it) and its position.
fn nearest(
    body: &Body,
    rb: &RigidBody,
    reach: Real,
    limit: Real,
    whole: &Across,
) -> Option<Nearest> {
    let dim = body.lattice.dim();
    let (lo, hi) = rb.bounds();
    let pos = &body.lattice.pos;
    let mut worst: Option<Nearest> = None;
    for i in whole.scan.clone() {
        let x = [pos.x()[i], pos.y()[i], pos.z()[i]];
        if (0..dim).any(|c| x[c] < lo[c] - limit || x[c] > hi[c] + limit) {
            continue;
        }
        if let Some((d, _)) = rb.signed_distance(x) {
            let gap = d - reach;
            if worst.is_none_or(|w| gap < w.1) {
                worst = Some(((whole.global)(i), gap, x));
            }
        }
    }
    (whole.nearest)(worst)
}

/// Place body `k` (its `start_gap`) and check that it starts clear of every node's contact
/// range: a body inside it would hit the node with the full penalty force at the first step.
pub fn place(
    body: &Body,
    k: usize,
    spec: &RigidSpec,
    reach: Real,
) -> Result<RigidBody, BuildError> {
    place_across(body, k, spec, reach, &Across::whole(body))
}

fn place_across(
    body: &Body,
    k: usize,
    spec: &RigidSpec,
    reach: Real,
    whole: &Across,
) -> Result<RigidBody, BuildError> {
    let dim = body.lattice.dim();
    let mut rb = spec.body.clone();
    if let Some(want) = spec.start_gap {
        let key = format!("rigid[{k}].start_gap");
        let want = positive(want, &key, "m")?;
        let v = rb.velocity;
        let speed = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if speed == 0.0 {
            return Err(BuildError::new(
                key,
                "the body is moved along its velocity, which is zero: give a velocity or place it by position",
            ));
        }
        let dir = v.map(|c| c / speed);
        // Along the velocity until the nearest gap is `want` (a few passes: exact for flat
        // faces, converging for curved ones).
        let size = body.lattice.spacing * (whole.nodes as Real).powf(1.0 / dim as Real) * 10.0;
        for _ in 0..20 {
            let Some((_, gap, _)) = nearest(body, &rb, reach, size, whole) else {
                break;
            };
            if (gap - want).abs() <= 1e-6 * want {
                break;
            }
            for c in 0..dim {
                rb.position[c] += (gap - want) * dir[c];
            }
        }
    }
    if let Some((i, gap, p)) = nearest(body, &rb, reach, reach, whole).filter(|w| w.1 < 0.0) {
        return Err(BuildError::new(
            format!("rigid[{k}].position"),
            format!(
                "the body starts {:.3e} m inside the contact range of node {i} at [{:e}, {:e}, {:e}] m (node contact radius {:e} m): move it at least that far away",
                -gap, p[0], p[1], p[2], reach
            ),
        ));
    }
    Ok(rb)
}

/// The contact of `body` with these options and bodies, each placed and checked.
pub fn contact(
    body: &Body,
    spec: &ContactSpec,
    bodies: &[RigidSpec],
) -> Result<Contact, BuildError> {
    contact_across(body, spec, bodies, &Across::whole(body))
}

/// [`contact`], the whole body's answers from `whole`.
pub(crate) fn contact_across(
    body: &Body,
    spec: &ContactSpec,
    bodies: &[RigidSpec],
    whole: &Across,
) -> Result<Contact, BuildError> {
    let opts = contact_options_across(body, spec, whole)?;
    let placed = bodies
        .iter()
        .enumerate()
        .map(|(k, s)| place_across(body, k, s, opts.radius, whole))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Contact::with_shortest(body, placed, opts, whole.shortest))
}
