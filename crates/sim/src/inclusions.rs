//! Random inclusions: non-overlapping spheres (3D) or disks (2D) placed inside a body, with a
//! size grading and a target volume fraction: the aggregates of concrete, the particles of a
//! composite. They become one phase ([`Shape::Balls`]).
//!
//! **Sizes.** Diameters are drawn from the grading, by number:
//!
//! - `Fuller { exponent: n }`: the volume of the inclusions finer than `d` is the share
//!   `(d^n - d_min^n) / (d_max^n - d_min^n)` of the whole (Fuller's curve, `n = 1/2`, between
//!   `d_min` and `d_max`). By number the density is then `d^(n - 1) / d^D`, with `D` the
//!   dimension (each inclusion's volume goes as `d^D`), and a diameter is drawn by inverting
//!   its distribution: `d = (d_min^e + u (d_max^e - d_min^e))^(1/e)`, `e = n - D`.
//! - `Uniform`: diameters uniform between `d_min` and `d_max`.
//!
//! Diameters are drawn until the next would pass the target volume, `fraction` times the
//! body's volume (the inclusions' own, not counting any `gap`).
//!
//! **Placing.** Largest first (take-and-place), each at a uniformly random point of the body's
//! bounding box shrunk by its radius, kept where the ball lies inside the body (its centre and
//! `2 D` points on its surface along the axes and, in 3D, 8 more along the diagonals, are in
//! the body) and clears every inclusion placed before by `gap`; a grid of cells the size of
//! the largest diameter finds the neighbours. An inclusion that finds no place in
//! [`TRIALS`] tries stops the generator, which reports the fraction it reached: a fraction
//! beyond random sequential packing's reach is refused with that number, never placed
//! partly. Random sequential addition jams near 0.38 (spheres of one size) and 0.55 (disks);
//! a grading lets the small ones fill the gaps between the large, which is how concrete
//! reaches 0.4 to 0.5 by volume of coarse aggregate.
//!
//! **Reproducible.** The draws come from one stream of the seed (SplitMix64), in one thread:
//! every process and thread count places the same inclusions.

use std::collections::HashMap;

use hooke_core::{Real, Vector};

use crate::geometry::{Shape, Solid};

/// Tries for one inclusion before the generator stops.
pub const TRIALS: usize = 20_000;

/// How the diameters are distributed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Grading {
    /// Fuller's curve of exponent `n` (1/2: Fuller and Thompson's ideal grading).
    Fuller { exponent: Real },
    /// Diameters uniform between the least and the largest.
    Uniform,
}

/// What to place: a grading between `d_min` and `d_max` (m), a target volume fraction of the
/// body, the least clearance between two inclusions (m), and a seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InclusionSpec {
    pub grading: Grading,
    pub d_min: Real,
    pub d_max: Real,
    pub fraction: Real,
    pub gap: Real,
    pub seed: u64,
}

/// Why inclusions were not placed: the message names the fix.
#[derive(Clone, Debug, PartialEq)]
pub enum InclusionError {
    /// A parameter out of range (which, and why).
    Bad(&'static str, String),
    /// The fraction could not be reached: the fraction placed when an inclusion found no
    /// place, and how many were placed of how many drawn.
    Unreached {
        reached: Real,
        placed: usize,
        drawn: usize,
    },
}

impl std::fmt::Display for InclusionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InclusionError::Bad(_, why) => write!(f, "{why}"),
            InclusionError::Unreached {
                reached,
                placed,
                drawn,
            } => write!(
                f,
                "the fraction cannot be reached: {placed} of the {drawn} inclusions drawn were placed, a volume fraction of {reached:.4}, when the next found no room in {TRIALS} tries; lower the fraction (or the gap), or widen the grading"
            ),
        }
    }
}

/// A set of non-overlapping balls (spheres; disks in 2D), found by a grid of cells.
#[derive(Clone, Debug)]
pub struct Balls {
    /// Centres and radii, largest first.
    pub balls: Vec<(Vector, Real)>,
    dim: usize,
    cell: Real,
    grid: HashMap<[i64; 3], Vec<u32>>,
}

impl Balls {
    fn new(dim: usize, cell: Real) -> Balls {
        Balls {
            balls: Vec::new(),
            dim,
            cell,
            grid: HashMap::new(),
        }
    }

    /// No balls (a phase whose inclusions are placed later).
    pub(crate) fn none(dim: usize) -> Balls {
        Balls::new(dim, 1.0)
    }

    fn key(&self, p: Vector) -> [i64; 3] {
        let k = |x: Real| (x / self.cell).floor() as i64;
        [k(p.x), k(p.y), if self.dim == 3 { k(p.z) } else { 0 }]
    }

    fn push(&mut self, c: Vector, r: Real) {
        let key = self.key(c);
        self.grid
            .entry(key)
            .or_default()
            .push(self.balls.len() as u32);
        self.balls.push((c, r));
    }

    /// The balls whose centres lie in the cells around `p`'s (every ball within one cell of
    /// it: a cell is at least a diameter wide).
    fn near(&self, p: Vector) -> impl Iterator<Item = &(Vector, Real)> + '_ {
        let [x, y, z] = self.key(p);
        let dz = if self.dim == 3 { -1..=1 } else { 0..=0 };
        dz.flat_map(move |k| {
            (-1..=1).flat_map(move |j| (-1..=1).map(move |i| [x + i, y + j, z + k]))
        })
        .filter_map(|key| self.grid.get(&key))
        .flatten()
        .map(|&b| &self.balls[b as usize])
    }

    fn distance(&self, a: Vector, b: Vector) -> Real {
        let mut d = a - b;
        if self.dim == 2 {
            d.z = 0.0;
        }
        d.norm()
    }

    /// `p` inside a ball, the surfaces moved out by `tol`.
    pub fn contains(&self, p: Vector, tol: Real) -> bool {
        self.near(p).any(|&(c, r)| self.distance(p, c) <= r + tol)
    }

    /// The balls' bounding box.
    pub fn bounds(&self) -> (Vector, Vector) {
        let mut lo = Vector::repeat(Real::INFINITY);
        let mut hi = Vector::repeat(Real::NEG_INFINITY);
        for &(c, r) in &self.balls {
            lo = lo.inf(&(c - Vector::repeat(r)));
            hi = hi.sup(&(c + Vector::repeat(r)));
        }
        (lo, hi)
    }

    /// Their volume (area in 2D).
    pub fn volume(&self) -> Real {
        self.balls
            .iter()
            .map(|&(_, r)| ball_volume(self.dim, r))
            .sum()
    }
}

/// The volume of a ball of radius `r` (area of a disk in 2D).
fn ball_volume(dim: usize, r: Real) -> Real {
    if dim == 3 {
        4.0 / 3.0 * std::f64::consts::PI * r * r * r
    } else {
        std::f64::consts::PI * r * r
    }
}

/// A stream of random numbers from a seed (SplitMix64), for the set-up's generators: the
/// same numbers on every process.
pub(crate) struct Stream(pub(crate) u64);

impl Stream {
    /// Uniform in [0, 1).
    pub(crate) fn next(&mut self) -> Real {
        let z = hooke_fracture::weibull::mix(self.0);
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (z >> 11) as Real * (1.0 / (1u64 << 53) as Real)
    }

    /// Standard normal (Box-Muller; `1 - u` in (0, 1] keeps the logarithm finite).
    pub(crate) fn normal(&mut self) -> Real {
        let (u, v) = (1.0 - self.next(), self.next());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

impl InclusionSpec {
    fn check(&self) -> Result<(), InclusionError> {
        let bad = |key, why: String| Err(InclusionError::Bad(key, why));
        if !(self.d_min.is_finite() && self.d_min > 0.0) {
            return bad(
                "d_min",
                format!("{}: give a positive diameter in m", self.d_min),
            );
        }
        if !(self.d_max.is_finite() && self.d_max >= self.d_min) {
            return bad(
                "d_max",
                format!(
                    "{}: give a diameter in m at least d_min ({})",
                    self.d_max, self.d_min
                ),
            );
        }
        if !(self.fraction > 0.0 && self.fraction < 1.0) {
            return bad(
                "fraction",
                format!("{}: give a volume fraction between 0 and 1", self.fraction),
            );
        }
        if !(self.gap.is_finite() && self.gap >= 0.0) {
            return bad(
                "gap",
                format!("{}: give a clearance of 0 m or more", self.gap),
            );
        }
        if let Grading::Fuller { exponent } = self.grading {
            if !(exponent > 0.0 && exponent < 1.0) {
                return bad(
                    "grading",
                    format!("Fuller exponent {exponent}: give one between 0 and 1 (0.5: Fuller and Thompson)"),
                );
            }
        }
        Ok(())
    }

    /// A diameter drawn from the grading (see the module docs).
    fn diameter(&self, dim: usize, u: Real) -> Real {
        let (a, b) = (self.d_min, self.d_max);
        if a == b {
            return a;
        }
        match self.grading {
            Grading::Uniform => a + u * (b - a),
            Grading::Fuller { exponent } => {
                let e = exponent - dim as Real;
                (a.powf(e) + u * (b.powf(e) - a.powf(e))).powf(1.0 / e)
            }
        }
    }
}

/// The volume (area in 2D) of `body`: its box's exactly, else the box's times the share of
/// the midpoints of a grid of cells (120^3, or 1000^2) inside it (within about 1 %; the same
/// on every process).
pub fn body_volume(body: &Solid, dim: usize) -> Result<Real, InclusionError> {
    let (lo, hi) = body
        .bounds(dim)
        .map_err(|e| InclusionError::Bad("geometry", e.to_string()))?;
    let size = hi - lo;
    let whole: Real = (0..dim).map(|k| size[k]).product();
    if body.add.is_empty() && body.subtract.is_empty() {
        return Ok(whole);
    }
    let n: usize = if dim == 3 { 120 } else { 1000 };
    let at = |k: usize, i: usize| lo[k] + (i as Real + 0.5) / n as Real * size[k];
    let inside: usize = (0..if dim == 3 { n } else { 1 })
        .map(|iz| {
            let mut count = 0;
            for iy in 0..n {
                for ix in 0..n {
                    let z = if dim == 3 { at(2, iz) } else { 0.0 };
                    count +=
                        usize::from(body.contains(Vector::new(at(0, ix), at(1, iy), z), 0.0, dim));
                }
            }
            count
        })
        .sum();
    Ok(whole * inside as Real / (n as Real).powi(dim as i32))
}

/// Place inclusions of `spec` inside `body` (see the module docs). Returns them, or why not.
pub fn place(spec: &InclusionSpec, body: &Solid, dim: usize) -> Result<Balls, InclusionError> {
    spec.check()?;
    let volume = body_volume(body, dim)?;
    let (lo, hi) = body
        .bounds(dim)
        .map_err(|e| InclusionError::Bad("geometry", e.to_string()))?;
    let size = hi - lo;
    if (0..dim).any(|c| size[c] < spec.d_max) {
        return Err(InclusionError::Bad(
            "d_max",
            format!(
                "inclusions of {} m do not fit in the body (its box is {:.4e} x {:.4e}{} m): give smaller ones",
                spec.d_max,
                size.x,
                size.y,
                if dim == 3 { format!(" x {:.4e}", size.z) } else { String::new() }
            ),
        ));
    }
    let mut rng = Stream(spec.seed);
    // The diameters, until the next would pass the target; then largest first.
    let target = spec.fraction * volume;
    let mut d = Vec::new();
    let mut total = 0.0;
    loop {
        let next = spec.diameter(dim, rng.next());
        let v = ball_volume(dim, 0.5 * next);
        if total + v > target {
            break;
        }
        total += v;
        d.push(next);
        if d.len() > 50_000_000 {
            return Err(InclusionError::Bad(
                "d_min",
                "over 5e7 inclusions: give a larger d_min".into(),
            ));
        }
    }
    d.sort_by(|a, b| b.total_cmp(a));
    let mut balls = Balls::new(dim, spec.d_max + spec.gap);
    let tol = 1e-9 * spec.d_min;
    let probes = surface_probes(dim);
    for (n, &di) in d.iter().enumerate() {
        let r = 0.5 * di;
        let mut placed = false;
        for _ in 0..TRIALS {
            let mut c = Vector::zeros();
            for k in 0..dim {
                c[k] = lo[k] + r + rng.next() * (size[k] - di);
            }
            let clear = balls
                .near(c)
                .all(|&(o, ro)| balls.distance(c, o) >= r + ro + spec.gap);
            if clear
                && body.contains(c, -tol, dim)
                && probes.iter().all(|p| body.contains(c + p * r, -tol, dim))
            {
                balls.push(c, r);
                placed = true;
                break;
            }
        }
        if !placed {
            return Err(InclusionError::Unreached {
                reached: balls.volume() / volume,
                placed: n,
                drawn: d.len(),
            });
        }
    }
    Ok(balls)
}

/// Unit directions at which a ball's surface is checked to lie in the body.
fn surface_probes(dim: usize) -> Vec<Vector> {
    let mut p = Vec::new();
    for k in 0..dim {
        for s in [-1.0, 1.0] {
            let mut v = Vector::zeros();
            v[k] = s;
            p.push(v);
        }
    }
    if dim == 3 {
        let h = 1.0 / (3.0 as Real).sqrt();
        for sx in [-h, h] {
            for sy in [-h, h] {
                for sz in [-h, h] {
                    p.push(Vector::new(sx, sy, sz));
                }
            }
        }
    } else {
        let h = 0.5 * (2.0 as Real).sqrt();
        for sx in [-h, h] {
            for sy in [-h, h] {
                p.push(Vector::new(sx, sy, 0.0));
            }
        }
    }
    p
}

impl From<Balls> for Shape {
    fn from(b: Balls) -> Shape {
        Shape::Balls(std::sync::Arc::new(b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxed(dim: usize, side: Real) -> (Solid, Real) {
        let hi = if dim == 3 {
            [side; 3]
        } else {
            [side, side, 0.0]
        };
        (Solid::cuboid([0.0; 3], hi), side.powi(dim as i32))
    }

    fn overlap_free(b: &Balls, gap: Real) {
        for (i, &(c, r)) in b.balls.iter().enumerate() {
            for &(o, ro) in &b.balls[..i] {
                assert!(b.distance(c, o) >= r + ro + gap - 1e-15, "{c} {o}");
            }
        }
    }

    /// A Fuller grading reaches 0.40 in a cube and 0.50 in a square (the targets),
    /// without overlaps, inside the body, the fraction placed within the last inclusion's
    /// volume of the target, the sizes between d_min and d_max.
    #[test]
    fn a_grading_reaches_the_target_fractions() {
        for (dim, side, fraction, d_min, d_max) in
            [(3, 0.1, 0.40, 4e-3, 16e-3), (2, 0.1, 0.50, 2e-3, 10e-3)]
        {
            let (body, volume) = boxed(dim, side);
            let spec = InclusionSpec {
                grading: Grading::Fuller { exponent: 0.5 },
                d_min,
                d_max,
                fraction,
                gap: 0.0,
                seed: 4,
            };
            let b = place(&spec, &body, dim).unwrap();
            let got = b.volume() / volume;
            let last = ball_volume(dim, 0.5 * d_max) / volume;
            assert!(got <= fraction && got > fraction - last, "{dim}D: {got}");
            overlap_free(&b, 0.0);
            for &(c, r) in &b.balls {
                assert!((0..dim).all(|k| c[k] - r >= -1e-12 && c[k] + r <= side + 1e-12));
                assert!(2.0 * r >= d_min && 2.0 * r <= d_max);
            }
            // Largest first, and the same on a second call.
            assert!(b.balls.windows(2).all(|w| w[0].1 >= w[1].1));
            let again = place(&spec, &body, dim).unwrap();
            assert_eq!(again.balls, b.balls);
        }
    }

    /// The grading's volume shares follow Fuller's curve: the volume finer than the middle
    /// diameter is within 0.05 of `(d^n - d_min^n) / (d_max^n - d_min^n)`.
    #[test]
    fn sizes_follow_fullers_curve() {
        let spec = InclusionSpec {
            grading: Grading::Fuller { exponent: 0.5 },
            d_min: 1e-3,
            d_max: 8e-3,
            fraction: 0.3,
            gap: 0.0,
            seed: 1,
        };
        for dim in [2, 3] {
            let mut rng = Stream(9);
            let d: Vec<Real> = (0..200_000)
                .map(|_| spec.diameter(dim, rng.next()))
                .collect();
            let v = |x: Real| x.powi(dim as i32);
            let total: Real = d.iter().map(|&x| v(x)).sum();
            for mid in [2e-3, 4e-3] {
                let finer: Real = d.iter().filter(|&&x| x < mid).map(|&x| v(x)).sum();
                let want = (mid.sqrt() - 1e-3f64.sqrt()) / (8e-3f64.sqrt() - 1e-3f64.sqrt());
                assert!(
                    (finer / total - want).abs() < 0.05,
                    "{dim}D {mid}: {} vs {want}",
                    finer / total
                );
            }
        }
    }

    /// A fraction beyond reach is refused with the fraction reached; a gap is kept; bad
    /// parameters are refused.
    #[test]
    fn what_cannot_be_placed_is_refused() {
        let (body, _) = boxed(3, 0.05);
        let spec = InclusionSpec {
            grading: Grading::Uniform,
            d_min: 8e-3,
            d_max: 8e-3,
            fraction: 0.6,
            gap: 0.0,
            seed: 2,
        };
        match place(&spec, &body, 3) {
            Err(InclusionError::Unreached {
                reached,
                placed,
                drawn,
            }) => {
                assert!(
                    reached > 0.1 && reached < 0.6 && placed < drawn,
                    "{reached}"
                );
            }
            other => panic!("{other:?}"),
        }
        let gap = InclusionSpec {
            fraction: 0.15,
            gap: 1e-3,
            ..spec
        };
        overlap_free(&place(&gap, &body, 3).unwrap(), 1e-3);
        for bad in [
            InclusionSpec {
                d_min: -1.0,
                ..spec
            },
            InclusionSpec {
                d_max: 1e-3,
                ..spec
            },
            InclusionSpec {
                fraction: 1.2,
                ..spec
            },
            InclusionSpec { d_max: 0.2, ..spec },
            InclusionSpec {
                grading: Grading::Fuller { exponent: 1.5 },
                ..spec
            },
        ] {
            assert!(matches!(
                place(&bad, &body, 3),
                Err(InclusionError::Bad(..))
            ));
        }
    }

    /// A body's volume: a box's exactly, a disk's within 0.1 %.
    #[test]
    fn volumes_of_bodies() {
        let (b, v) = boxed(3, 0.2);
        assert_eq!(body_volume(&b, 3).unwrap(), v);
        let disk = Solid {
            bbox: None,
            add: vec![Shape::ball([0.0; 3], 1.0)],
            subtract: Vec::new(),
        };
        let a = body_volume(&disk, 2).unwrap();
        assert!((a / std::f64::consts::PI - 1.0).abs() < 1e-3, "{a}");
    }

    #[test]
    fn balls_contain_their_points() {
        let (body, _) = boxed(2, 0.05);
        let spec = InclusionSpec {
            grading: Grading::Fuller { exponent: 0.5 },
            d_min: 2e-3,
            d_max: 6e-3,
            fraction: 0.4,
            gap: 0.0,
            seed: 3,
        };
        let b = place(&spec, &body, 2).unwrap();
        let shape = Shape::from(b.clone());
        for &(c, r) in &b.balls {
            assert!(shape.contains(c, 0.0, 2));
            assert!(shape.contains(c + Vector::new(0.99 * r, 0.0, 0.0), 0.0, 2));
        }
        // A point of the box outside every ball.
        let mut rng = Stream(5);
        let mut outside = 0;
        for _ in 0..1000 {
            let p = Vector::new(0.05 * rng.next(), 0.05 * rng.next(), 0.0);
            let brute = b.balls.iter().any(|&(c, r)| (p - c).xy().norm() <= r);
            assert_eq!(shape.contains(p, 0.0, 2), brute);
            outside += usize::from(!brute);
        }
        assert!(outside > 300);
    }
}
