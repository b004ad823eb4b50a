//! What a simulation would do, measured before it runs: [`Simulation::check`] builds the
//! integrator, times a few steps on a copy of the state, writes one frame and one checkpoint
//! into a scratch folder (so that the peak memory includes them), and reports the constants,
//! the time step, the memory and the notes on calibrated ranges as a typed [`CheckReport`].
//! `hooke check` renders it as text or `--json`; Python reads the same object.

use std::path::Path;
use std::time::Instant;

use hooke_core::dynamics::Integrator;
use hooke_core::Real;
use serde::Serialize;

use crate::{Error, Result, Simulation};

/// The report of [`Simulation::check`]. Its JSON form is `hooke check --json`'s object (the
/// spring constant under `k`, or `kappa` on random lattices).
#[derive(Clone, Debug, Serialize)]
pub struct CheckReport {
    pub valid: bool,
    pub lattice: &'static str,
    pub kernel: &'static str,
    pub spacing: Real,
    pub nodes: usize,
    pub springs: usize,
    pub springs_precracked: usize,
    pub cell_weights: bool,
    pub q: Real,
    /// The isotropic Poisson's ratio the springs give (`None` for anisotropic materials).
    pub nu: Option<Real>,
    /// `k` (N/m) on regular lattices, `kappa` (Pa, or N/m on plates) on random ones.
    #[serde(skip)]
    pub k: Real,
    #[serde(rename = "k", skip_serializing_if = "Option::is_none")]
    k_regular: Option<Real>,
    #[serde(rename = "kappa", skip_serializing_if = "Option::is_none")]
    k_random: Option<Real>,
    /// The breaking criterion (`Debug` form), if springs break.
    pub criterion: Option<String>,
    pub rigid_bodies: usize,
    pub boundaries: Vec<BoundaryNodes>,
    pub dt: Real,
    pub dt_critical: Real,
    pub steps: Real,
    pub end_time: Real,
    pub quasi_static_steps: Option<usize>,
    /// Heap bytes of the body, the state and the integrator with its kernel (their footprints).
    pub state_bytes: usize,
    /// Peak resident memory of the process while checking (set-up, a few steps, a frame and a
    /// checkpoint), where the system tells it.
    pub peak_memory_bytes: Option<u64>,
    pub seconds_per_step: f64,
    pub estimated_seconds: f64,
    /// Estimated bytes of output the run writes.
    pub output_bytes: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub anisotropic: Option<serde_json::Value>,
    /// Softening springs: their shape and calibrated factors.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub softening: Option<SofteningReport>,
    /// A body of several materials: each phase, its nodes and springs and their strength.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub phases: Vec<PhaseReport>,
    /// Springs that join two materials (a body of several materials).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interface_springs: Option<usize>,
    /// The springs' own strength factors (a material's or interface's strength, a Weibull
    /// scatter): least, mean and largest, where they have them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strength_factors: Option<[Real; 3]>,
    /// Where the case lies outside a calibrated range, and what that costs.
    pub notes: Vec<Note>,
}

/// One phase of a body of several materials, as `hooke check` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct PhaseReport {
    #[serde(flatten)]
    pub material: crate::MaterialInfo,
    /// Its nodes, and the springs between two of them.
    pub nodes: usize,
    pub springs: usize,
    /// The least, mean and largest critical stretch of those springs (a critical-stretch
    /// criterion; they differ where the springs scatter).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub critical_stretch: Option<[Real; 3]>,
}

/// A boundary region and its node count.
#[derive(Clone, Debug, Serialize)]
pub struct BoundaryNodes {
    pub name: String,
    pub nodes: usize,
}

/// Softening springs as calibrated for this lattice and nu.
#[derive(Clone, Debug, Serialize)]
pub struct SofteningReport {
    pub shape: &'static str,
    pub peak: Real,
    pub last: Real,
    pub equivalent_stretch: Real,
    pub peak_fraction: Real,
    /// F, the measured toughness factor over the brittle calibration.
    pub toughness_factor: Real,
    /// S: a body's tensile strength is `S E` times the peak stretch (`None` where it was not
    /// measured on this lattice: the springs then peak at f_t / E).
    pub strength_factor: Option<Real>,
}

/// A note on a calibrated range: which calibration (`jitter-sampler`, `toughness`, `softening`,
/// `energy-criterion`) and what it means here.
#[derive(Clone, Debug, Serialize)]
pub struct Note {
    pub about: &'static str,
    pub text: String,
}

/// Steps timed on a copy of the state for the estimate.
const TRIAL_STEPS: usize = 5;

impl Simulation {
    /// Build the integrator, time a few steps on a copy of the state, write one frame and one
    /// checkpoint into `scratch` (removed afterwards), and report (see the module docs). The
    /// simulation itself is not stepped.
    pub fn check(&mut self, scratch: &Path) -> Result<CheckReport> {
        let it = Integrator::new(
            &self.body,
            &mut self.state,
            self.loading.clone(),
            &self.options,
        )
        .map_err(Error::Core)?;
        let mut probe = self.state.clone();
        let mut it2 = Integrator::new(&self.body, &mut probe, self.loading.clone(), &self.options)
            .map_err(Error::Core)?;
        let t0 = Instant::now();
        for _ in 0..TRIAL_STEPS {
            it2.step(&self.body, &mut probe);
        }
        let per_step = t0.elapsed().as_secs_f64() / TRIAL_STEPS as f64;
        std::fs::create_dir_all(scratch).map_err(|source| Error::File {
            what: format!("creating {}", scratch.display()),
            source,
        })?;
        let written = crate::write_probe(self, &probe, &it2, scratch);
        let _ = std::fs::remove_dir_all(scratch);
        written?;
        let state_bytes = [
            self.body.footprint(),
            self.state.footprint(),
            it.footprint(),
        ]
        .iter()
        .flatten()
        .map(|(_, b)| b)
        .sum();
        let kind = self.body.lattice.kind;
        let steps = (self.end_time / it.dt()).ceil();
        let anisotropic = self.anisotropic_report()?;
        Ok(CheckReport {
            valid: true,
            lattice: kind.name(),
            kernel: it.kernel().name(),
            spacing: self.body.lattice.spacing,
            nodes: self.body.nodes(),
            springs: self.body.springs(),
            springs_precracked: self.precracked,
            cell_weights: self.cell_weighted,
            q: self.q,
            nu: anisotropic
                .is_none()
                .then(|| hooke_core::material::nu_from_q(kind, self.q)),
            k: self.k,
            k_regular: (!kind.is_random()).then_some(self.k),
            k_random: kind.is_random().then_some(self.k),
            criterion: self
                .fracture
                .as_ref()
                .map(|f| format!("{:?}", f.criterion())),
            rigid_bodies: self.contact.as_ref().map_or(0, |c| c.bodies.len()),
            boundaries: self
                .boundaries
                .iter()
                .map(|b| BoundaryNodes {
                    name: b.name.clone(),
                    nodes: b.nodes.len(),
                })
                .collect(),
            dt: it.dt(),
            dt_critical: it.stable().dt_critical,
            steps,
            end_time: self.end_time,
            quasi_static_steps: self.solver.quasi_static_steps(),
            state_bytes,
            peak_memory_bytes: hooke_sys::peak_memory(),
            seconds_per_step: per_step,
            estimated_seconds: per_step * steps,
            output_bytes: self.output_estimate(),
            anisotropic,
            softening: self.softening_report(),
            phases: self.phase_report(),
            strength_factors: self
                .fracture
                .as_ref()
                .and_then(|f| f.strength())
                .filter(|f| !f.is_empty())
                .map(|f| {
                    let (lo, hi) = f
                        .iter()
                        .fold((Real::INFINITY, 0.0), |(lo, hi): (Real, Real), &x| {
                            (lo.min(x), hi.max(x))
                        });
                    [lo, f.iter().sum::<Real>() / f.len() as Real, hi]
                }),
            interface_springs: self.body.phase.as_ref().map(|p| {
                let ends = &self.body.lattice.bonds.ends;
                ends.iter()
                    .filter(|e| p[e[0] as usize] != p[e[1] as usize])
                    .count()
            }),
            notes: self.notes(),
        })
    }

    /// Each phase's nodes, springs and critical stretches (see [`PhaseReport`]).
    fn phase_report(&self) -> Vec<PhaseReport> {
        let Some(phase) = &self.body.phase else {
            return Vec::new();
        };
        let nodes = self.phase_nodes();
        let screen = self.fracture.as_ref().and_then(|f| {
            let c = f.criterion();
            c.screen()
                .filter(|_| c.as_softening().is_none() && !c.is_energy())
        });
        let factor = self.fracture.as_ref().and_then(|f| f.strength());
        let mut springs = vec![0usize; self.materials.len()];
        let mut range = vec![[Real::INFINITY, 0.0, 0.0]; self.materials.len()];
        for (b, e) in self.body.lattice.bonds.ends.iter().enumerate() {
            let [p, q] = e.map(|v| phase[v as usize] as usize);
            if p != q || p >= springs.len() {
                continue;
            }
            springs[p] += 1;
            let s = screen.unwrap_or(Real::NAN) * factor.map_or(1.0, |f| f[b]);
            let r = &mut range[p];
            *r = [r[0].min(s), r[1] + s, r[2].max(s)];
        }
        self.materials
            .iter()
            .enumerate()
            .map(|(p, m)| PhaseReport {
                material: m.clone(),
                nodes: nodes[p],
                springs: springs[p],
                critical_stretch: (screen.is_some() && springs[p] > 0).then(|| {
                    let r = range[p];
                    [r[0], r[1] / springs[p] as Real, r[2]]
                }),
            })
            .collect()
    }

    /// The anisotropic material's design or spring families and its stiffness, as `hooke check
    /// --json` prints them.
    fn anisotropic_report(&self) -> Result<Option<serde_json::Value>> {
        let material = |e: hooke_core::Error| Error::Core(e);
        if let (Some(m), Some(cal)) = (&self.anisotropic, &self.random_design) {
            let d = &cal.design;
            let plate = self.body.lattice.dim() == 2;
            let mut v = serde_json::json!({
                "material": format!("{m:?}"),
                "kappa": d.kappa, "kappa_terms": ["xx", "yy", "zz", "yz", "xz", "xy"],
                "alpha": d.alpha, "axes": d.axes, "sharpness": d.sharpness,
                "calibration_residuals": cal.residuals, "calibration_held_out": cal.held_out,
                "calibration_seconds": cal.seconds,
                "calibration_cache_file": cal.cache.file().map(|p| p.display().to_string()),
                "calibration_from_cache": matches!(cal.cache, hooke_core::random::anisotropic::Cached::Read(_)),
                "stiffness": if plate { m.plane_stiffness(self.plane).map_err(material)? } else { m.stiffness().map_err(material)? },
            });
            if plate {
                v["plane"] = serde_json::json!(self.plane.name());
            }
            return Ok(Some(v));
        }
        let Some(m) = &self.anisotropic else {
            return Ok(None);
        };
        let f = m.families(self.body.lattice.spacing).map_err(material)?;
        Ok(Some(serde_json::json!({
            "material": format!("{m:?}"),
            "axis_stiffness": f.axis_k, "diagonal_stiffness": f.diagonal_k,
            "axis_weights": f.axis_w, "diagonal_weights": f.diagonal_w,
            "stiffness": m.stiffness().map_err(material)?,
        })))
    }

    fn softening_report(&self) -> Option<SofteningReport> {
        let law = self.fracture.as_ref()?.criterion().as_softening()?;
        let kind = self.body.lattice.kind;
        let nu = hooke_core::material::nu_from_q(kind, self.q);
        let rho = law.peak / law.equivalent_stretch();
        Some(SofteningReport {
            shape: law.shape.name(),
            peak: law.peak,
            last: law.last,
            equivalent_stretch: law.equivalent_stretch(),
            peak_fraction: rho,
            toughness_factor: hooke_fracture::softening::toughness_factor(kind, nu, rho, law.shape),
            strength_factor: hooke_fracture::softening::strength_factor(kind, nu, rho, law.shape),
        })
    }

    /// Where this case lies outside a calibrated range.
    fn notes(&self) -> Vec<Note> {
        let kind = self.body.lattice.kind;
        let nu = hooke_core::material::nu_from_q(kind, self.q);
        let mut notes = Vec::new();
        if let Some(c) = &self.body.lattice.cells {
            if !hooke_core::random::calibration::calibrated(kind, c.sampler) {
                notes.push(Note {
                    about: "jitter-sampler",
                    text: format!(
                        "the {:?} sampler is calibrated only at amplitude {}: E and nu are met \
                         only roughly (measure them with hooke moduli --sampler jitter)",
                        c.sampler,
                        hooke_core::random::calibration::JITTER_CALIBRATED
                    ),
                });
            }
        }
        // (A body of several materials: each material's G_c is converted with its own q.)
        if self.fracture.is_some()
            && self.materials.is_empty()
            && !hooke_fracture::stretch::toughness_calibrated(kind, self.q)
        {
            notes.push(Note {
                about: "toughness",
                text: format!(
                    "nu = {nu:.3} lies outside the range where the lattice toughness was \
                     measured (hooke toughness): cracks leave their plane there and G_c is \
                     matched only roughly"
                ),
            });
        }
        if let Some(s) = self.softening_report() {
            if !hooke_fracture::softening::calibrated(kind, nu, s.peak_fraction) {
                notes.push(Note {
                    about: "softening",
                    text: format!(
                        "softening springs are calibrated for nu in [-0.5, 0.25] and peak \
                         fractions in [0.35, 0.9] on hex, random2d and cubic lattices (random3d \
                         takes the cubic table); here (nu = {nu:.3}, peak fraction {:.3}) the \
                         table's edge values are used and G_f is met only roughly",
                        s.peak_fraction
                    ),
                });
            }
        }
        if let Some(f) = &self.fracture {
            if f.criterion().is_energy() && !hooke_fracture::energy::energy_calibrated(kind, nu) {
                notes.push(Note {
                    about: "energy-criterion",
                    text: format!(
                        "the energy criterion's G_c calibration holds for hex nu_2D in \
                         [-0.9, 0.5] and cubic nu in [-0.1, 0.4]; at nu = {nu:.3} its crack \
                         roughens and G_c is matched only roughly (the stretch criterion covers \
                         more)"
                    ),
                });
            }
        }
        notes
    }
}
