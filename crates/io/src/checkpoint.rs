//! Checkpoints: everything needed to continue a run bit for bit.
//!
//! Little-endian binary, version 3:
//!
//! ```text
//! "HOOKECK1"  u32 version  u64 case digest  u64 nodes  u64 springs  u64 step  f64 time
//! f64 dt  f64 x5 ledger (external, boundary, body, dissipated, released)  f64 initial
//! f64 initial power  f64 x3 stable step (lambda_max, dt_critical, lambda_bound)
//! u64 springs broken  f64 energy released
//! f64 x 3n displacements (x..., y..., z...)  f64 x 3n half-step velocities  u8 x springs alive
//! u64 extra count k, f64 x k extra values (version 2: what the caller keeps beside the lattice,
//! e.g. the rigid bodies and contact counters)
//! u64 weight count w (0, or springs once a softening material damaged a spring), f64 x w
//! damage weights (version 3; 0 for a broken spring)
//! u64 FNV-1a checksum of everything before it
//! ```
//!
//! Version 1 files (without the extra values) and version 2 files (without the weights) still
//! load.
//!
//! The normalisers `S_n` are not stored: they follow from the intact springs. A checkpoint names
//! the case it belongs to by a digest, and [`Checkpoint::load`] refuses another case, another
//! body size or a damaged file.

use std::path::Path;

use hooke_core::dynamics::{IntegratorCheckpoint, Ledger};
use hooke_core::stability::StableStep;
use hooke_core::{Body, Real, State};

use crate::error::{io, IoError};
use crate::vtk::write_atomic;

const MAGIC: &[u8; 8] = b"HOOKECK1";
const VERSION: u32 = 3;

/// A run's state at one step.
#[derive(Clone, Debug)]
pub struct Checkpoint {
    pub digest: u64,
    pub state: State,
    pub integrator: IntegratorCheckpoint,
    /// Fracture counters: springs broken and energy released so far.
    pub broken: u64,
    pub released: Real,
    /// State the caller keeps beside the lattice (rigid bodies, contact), restored verbatim.
    pub extra: Vec<Real>,
}

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// A 64-bit digest of a case's text (or any bytes that define a run).
pub fn digest(bytes: &[u8]) -> u64 {
    fnv1a(bytes)
}

impl Checkpoint {
    /// Save atomically to `path`.
    pub fn save(&self, path: &Path) -> Result<(), IoError> {
        let s = &self.state;
        let n = s.u.len();
        let mut b: Vec<u8> = Vec::with_capacity(128 + 48 * n + s.alive().len());
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&VERSION.to_le_bytes());
        for v in [self.digest, n as u64, s.alive().len() as u64, s.step] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let ck = &self.integrator;
        let l = &ck.ledger;
        for v in [
            s.time,
            ck.dt,
            l.external_work,
            l.boundary_work,
            l.body_work,
            l.dissipated,
            l.released,
            ck.initial,
            ck.initial_power,
            ck.stable.lambda_max,
            ck.stable.dt_critical,
            ck.stable.lambda_bound,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.broken.to_le_bytes());
        b.extend_from_slice(&self.released.to_le_bytes());
        for c in [&s.u, &s.v] {
            for comp in 0..3 {
                for v in c.comp(comp) {
                    b.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        b.extend(s.alive().iter().map(|&a| a as u8));
        b.extend_from_slice(&(self.extra.len() as u64).to_le_bytes());
        for v in &self.extra {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let weights = if s.is_softened() {
            s.weights()
        } else {
            Vec::new()
        };
        b.extend_from_slice(&(weights.len() as u64).to_le_bytes());
        for v in &weights {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let sum = fnv1a(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        write_atomic(path, |w| w.write_all(&b).map_err(io(path)))
    }

    /// The simulated time a checkpoint was written at, from its header alone (what a process
    /// of a run on pieces needs before it has the piece that [`Checkpoint::load`] checks the
    /// file against); `None` if it is not a readable checkpoint.
    pub fn time_of(path: &Path) -> Option<Real> {
        use std::io::Read;
        let mut head = [0u8; 8 + 4 + 32 + 8];
        std::fs::File::open(path).ok()?.read_exact(&mut head).ok()?;
        (&head[..8] == MAGIC).then(|| Real::from_le_bytes(head[44..52].try_into().unwrap()))
    }

    /// Load from `path` for `body`; refuses a checkpoint of another case (`digest`) or body.
    pub fn load(path: &Path, body: &Body, digest: u64) -> Result<Self, IoError> {
        let bytes = std::fs::read(path).map_err(io(path))?;
        let bad = |why: String| IoError::Format {
            path: path.to_path_buf(),
            why,
        };
        // Header (signature, version, four u64) plus the checksum, before anything is read.
        if bytes.len() < 8 + 4 + 32 + 8 || &bytes[..8] != MAGIC {
            return Err(bad(
                "it does not start with the hooke checkpoint signature".into()
            ));
        }
        let (body_bytes, tail) = bytes.split_at(bytes.len() - 8);
        if fnv1a(body_bytes).to_le_bytes() != tail {
            return Err(bad(
                "checksum mismatch: the file is truncated or corrupted".into()
            ));
        }
        let mut r = Reader {
            b: body_bytes,
            at: 8,
        };
        let version = u32::from_le_bytes(r.take(4).try_into().unwrap());
        if !(1..=VERSION).contains(&version) {
            return Err(bad(format!(
                "version {version}, this hooke reads version {VERSION}"
            )));
        }
        let found = r.u64();
        if found != digest {
            return Err(IoError::DigestMismatch {
                path: path.to_path_buf(),
                found,
                expected: digest,
            });
        }
        let (n, springs) = (r.u64() as usize, r.u64() as usize);
        if n != body.nodes() || springs != body.springs() {
            return Err(bad(format!(
                "it holds {n} nodes and {springs} springs, the body has {} and {}",
                body.nodes(),
                body.springs()
            )));
        }
        expected_length(body_bytes, version, n, springs).map_err(bad)?;
        let step = r.u64();
        let f: Vec<Real> = (0..12).map(|_| r.f64()).collect();
        let broken = r.u64();
        let released = r.f64();
        let (mut state, extra) = read_state(&mut r, body, version, springs).map_err(bad)?;
        state.step = step;
        state.time = f[0];
        let integrator = IntegratorCheckpoint {
            dt: f[1],
            ledger: Ledger {
                external_work: f[2],
                boundary_work: f[3],
                body_work: f[4],
                dissipated: f[5],
                released: f[6],
            },
            initial: f[7],
            initial_power: f[8],
            stable: StableStep {
                lambda_max: f[9],
                dt_critical: f[10],
                lambda_bound: f[11],
            },
        };
        Ok(Checkpoint {
            digest: found,
            state,
            integrator,
            broken,
            released,
            extra,
        })
    }
}

/// The state's part of a checkpoint, after its header: displacements, velocities, which
/// springs are intact, the integrator's extra values (version 2) and the springs' weights
/// (version 3).
fn read_state(
    r: &mut Reader<'_>,
    body: &Body,
    version: u32,
    springs: usize,
) -> Result<(State, Vec<Real>), String> {
    let mut state = State::new(body);
    for c in 0..3 {
        for v in state.u.comp_mut(c) {
            *v = r.f64();
        }
    }
    for c in 0..3 {
        for v in state.v.comp_mut(c) {
            *v = r.f64();
        }
    }
    let alive: Vec<bool> = (0..springs).map(|_| r.take(1)[0] != 0).collect();
    // An intact body's state stays as `State::new` made it (the same normalisers), so a
    // box resumed intact still reads its grid rather than building its rows.
    if alive.iter().any(|&a| !a) {
        state.set_alive(body, alive);
    }
    let extra = if version >= 2 {
        let k = r.u64() as usize;
        (0..k).map(|_| r.f64()).collect()
    } else {
        Vec::new()
    };
    if version >= 3 {
        let w = r.u64() as usize;
        if w > 0 {
            let weights: Vec<Real> = (0..w).map(|_| r.f64()).collect();
            if weights.iter().any(|v| !(0.0..=1.0).contains(v)) {
                return Err("a spring weight outside [0, 1]".into());
            }
            state.set_weights(body, &weights);
        }
    }
    Ok((state, extra))
}

/// Check that a checkpoint of `version` holding `n` nodes and `springs` springs has the
/// length its counts give (`bytes`: the file before its checksum): the fixed part, the
/// integrator's extra values (version 2) and the spring weights (version 3).
fn expected_length(bytes: &[u8], version: u32, n: usize, springs: usize) -> Result<(), String> {
    let count_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    let fixed = 8 + 4 + 8 * 4 + 8 * 12 + 16 + 48 * n + springs;
    let extra_len = if version >= 2 && bytes.len() >= fixed + 8 {
        count_at(fixed) as usize
    } else {
        0
    };
    let mut expected = if version >= 2 {
        fixed + 8 + 8 * extra_len
    } else {
        fixed
    };
    if version >= 3 && bytes.len() >= expected + 8 {
        let w = count_at(expected);
        if w != 0 && w as usize != springs {
            return Err(format!("{w} spring weights for {springs} springs"));
        }
        expected += 8 + 8 * w as usize;
    }
    if bytes.len() != expected {
        return Err(format!(
            "{} bytes where {expected} were expected",
            bytes.len()
        ));
    }
    Ok(())
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> &'a [u8] {
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        s
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn f64(&mut self) -> Real {
        Real::from_le_bytes(self.take(8).try_into().unwrap())
    }
}
