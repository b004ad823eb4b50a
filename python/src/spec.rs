//! A simulation built in Python: `hooke.Builder` (a `#[pyclass]` over [`Pending`]) applies each
//! call to `hooke_sim::Builder` as it is made. Arguments arrive as plain data (numbers, strings,
//! lists and dicts: what `hooke.Face`, `hooke.Sphere`, `hooke.ramp` and friends stand for), so
//! every check and every error message is the library's (`BuildError` names the item), except
//! the arguments' own shape, checked here with the call's name.

use hooke_contact::{Geometry, Motion, RigidBody};
use hooke_core::dynamics::TimeStep;
use hooke_core::loading::TimeFunction;
use hooke_core::random::{RandomSpec, Sampler};
use hooke_core::{LatticeKind, PlaneModel, Real, Vector};
use hooke_fracture::Crack;
use hooke_fracture::SofteningShape;
use hooke_sim::{
    Bc, BreakRule, Builder, ContactSpec, Region, RigidSpec, Shape, Simulation, Solid, Strength,
};
use serde_json::Value;

type R<T> = Result<T, String>;

fn num(v: &Value, key: &str) -> R<Real> {
    v.as_f64()
        .ok_or_else(|| format!("{key}: give a number, not {v}"))
}

/// A point: 2 or 3 numbers (z = 0 when 2).
fn point(v: &Value, key: &str) -> R<[Real; 3]> {
    let a = v
        .as_array()
        .filter(|a| a.len() == 2 || a.len() == 3)
        .ok_or_else(|| format!("{key}: give [x, y] or [x, y, z], not {v}"))?;
    let mut p = [0.0; 3];
    for (c, x) in a.iter().enumerate() {
        p[c] = num(x, key)?;
    }
    Ok(p)
}

/// A positive, finite number.
fn positive(v: &Value, key: &str) -> R<Real> {
    let x = num(v, key)?;
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("{key}: {x}: give a positive number"))
    }
}

fn axis(v: &Value, key: &str) -> R<usize> {
    match v.as_str() {
        Some("x") => Ok(0),
        Some("y") => Ok(1),
        Some("z") => Ok(2),
        _ => Err(format!("{key}: give \"x\", \"y\" or \"z\", not {v}")),
    }
}

fn field<'a>(v: &'a Value, name: &str, key: &str) -> R<&'a Value> {
    v.get(name)
        .ok_or_else(|| format!("{key}: missing \"{name}\""))
}

/// A time function: a number (constant), or `{"ramp"|"smooth": [t0, t1, from, to]}`, or
/// `{"table": [[t, v], ...]}`.
fn time_function(v: &Value, key: &str) -> R<TimeFunction> {
    if let Some(c) = v.as_f64() {
        return Ok(TimeFunction::Constant(c));
    }
    let four = |w: &Value| -> R<[Real; 4]> {
        let a = w
            .as_array()
            .filter(|a| a.len() == 4)
            .ok_or_else(|| format!("{key}: give [t0, t1, from, to]"))?;
        Ok([
            num(&a[0], key)?,
            num(&a[1], key)?,
            num(&a[2], key)?,
            num(&a[3], key)?,
        ])
    };
    if let Some(w) = v.get("ramp") {
        let [t0, t1, from, to] = four(w)?;
        return Ok(TimeFunction::Ramp { t0, t1, from, to });
    }
    if let Some(w) = v.get("smooth") {
        let [t0, t1, from, to] = four(w)?;
        return Ok(TimeFunction::SmoothRamp { t0, t1, from, to });
    }
    if let Some(Value::Array(rows)) = v.get("table") {
        let pts = rows
            .iter()
            .map(|r| {
                let p = point(r, key)?;
                Ok((p[0], p[1]))
            })
            .collect::<R<Vec<_>>>()?;
        return Ok(TimeFunction::Table(pts));
    }
    Err(format!("{key}: give a number, {{\"ramp\": [t0, t1, from, to]}}, {{\"smooth\": [...]}} or {{\"table\": [[t, v], ...]}}, not {v}"))
}

fn shape(v: &Value, key: &str) -> R<Shape> {
    if let Some(b) = v.get("box") {
        return Ok(Shape::cuboid(
            point(field(b, "min", key)?, key)?,
            point(field(b, "max", key)?, key)?,
        ));
    }
    if let Some(s) = v.get("sphere") {
        return Ok(Shape::ball(
            point(field(s, "center", key)?, key)?,
            num(field(s, "radius", key)?, key)?,
        ));
    }
    if let Some(c) = v.get("cylinder") {
        return Ok(Shape::Cylinder {
            c: Vector::from(point(field(c, "center", key)?, key)?),
            axis: axis(field(c, "axis", key)?, key)?,
            r: num(field(c, "radius", key)?, key)?,
            half: 0.5 * num(field(c, "length", key)?, key)?,
        });
    }
    Err(format!("{key}: give {{\"box\": {{min, max}}}}, {{\"sphere\": {{center, radius}}}} or {{\"cylinder\": {{center, axis, radius, length}}}}, not {v}"))
}

fn region(v: &Value, key: &str) -> R<Region> {
    if v.as_str() == Some("all") {
        return Ok(Region::All);
    }
    if let Some(f) = v.get("face").and_then(Value::as_str) {
        return hooke_sim::Face::parse(f, 3)
            .map(Region::Face)
            .ok_or_else(|| format!("{key}: face \"{f}\": give x-, x+, y-, y+, z- or z+"));
    }
    if let Some(b) = v.get("box") {
        return Ok(Region::Box {
            lo: Vector::from(point(field(b, "min", key)?, key)?),
            hi: Vector::from(point(field(b, "max", key)?, key)?),
        });
    }
    if let Some(p) = v.get("plane") {
        return Ok(Region::Plane {
            axis: axis(field(p, "axis", key)?, key)?,
            at: num(field(p, "at", key)?, key)?,
            tolerance: p.get("tolerance").map(|t| num(t, key)).transpose()?,
        });
    }
    if let Some(Value::Array(ns)) = v.get("nodes") {
        let nodes = ns
            .iter()
            .map(|n| {
                n.as_u64()
                    .and_then(|n| u32::try_from(n).ok())
                    .ok_or_else(|| format!("{key}: node {n} is not a node index"))
            })
            .collect::<R<Vec<_>>>()?;
        return Ok(Region::Nodes(nodes));
    }
    if let Some(s) = v.get("inside") {
        return Ok(Region::Inside(shape(s, key)?));
    }
    Err(format!("{key}: give \"all\", {{\"face\": \"y+\"}}, {{\"box\": {{min, max}}}}, {{\"plane\": {{axis, at}}}}, {{\"inside\": SHAPE}} or {{\"nodes\": [...]}}, not {v}"))
}

/// A rigid body (the case file's `[[rigid]]`, without `start_gap`), `dim` the lattice's.
fn rigid(a: &Value, key: &str, dim: usize, thickness: Real, k: usize) -> R<RigidBody> {
    let sh = field(a, "shape", key)?;
    let geometry = rigid_geometry(sh, key, dim)?;
    let position = point(field(a, "position", key)?, key)?;
    let velocity = match a.get("velocity") {
        Some(v) => point(v, key)?,
        None => [0.0; 3],
    };
    if position.iter().chain(&velocity).any(|x| !x.is_finite()) {
        return Err(format!("{key}: position and velocity must be finite"));
    }
    let motion = rigid_motion(a, key, &geometry, velocity, thickness)?;
    let friction = match a.get("friction") {
        None => 0.0,
        Some(f) => {
            let x = num(f, key)?;
            if !(x.is_finite() && x >= 0.0) {
                return Err(format!(
                    "{key}: friction {x}: give a Coulomb coefficient >= 0"
                ));
            }
            x
        }
    };
    let name = match a.get("name").and_then(Value::as_str) {
        Some(n) => n.to_string(),
        None => format!("rigid{k}"),
    };
    let flat = |p: [Real; 3]| [p[0], p[1], if dim == 3 { p[2] } else { 0.0 }];
    let rotates = match a.get("rotates") {
        None => None,
        Some(r) => Some(
            r.as_bool()
                .ok_or_else(|| format!("{key}: rotates: give true or false"))?,
        ),
    };
    let spin: Option<Vec<Real>> = match a.get("angular_velocity") {
        None => None,
        Some(w) => Some(
            w.as_array()
                .and_then(|v| v.iter().map(Value::as_f64).collect::<Option<Vec<Real>>>())
                .ok_or_else(|| {
                    format!("{key}: angular_velocity: give a list of numbers (rad/s)")
                })?,
        ),
    };
    RigidBody::new(
        name,
        geometry,
        motion,
        flat(position),
        flat(velocity),
        friction,
    )
    .with_spin_settings(rotates, spin.as_deref(), dim)
    .map_err(|(which, why)| format!("{key}: {which}: {why}"))
}

/// A rigid body's shape from its `shape` argument.
fn rigid_geometry(sh: &Value, key: &str, dim: usize) -> R<Geometry> {
    let pos = |v: &Value, what: &str| positive(v, &format!("{key}: {what}"));
    let axis_or_z = |v: &Value| -> R<usize> {
        match v.get("axis") {
            Some(x) => axis(x, key),
            None => Ok(2),
        }
    };
    let geometry = if let Some(b) = sh.get("sphere") {
        Geometry::ball(dim, pos(field(b, "radius", key)?, "radius")?)
    } else if let Some(b) = sh.get("box") {
        let size = point(field(b, "size", key)?, key)?;
        if size[..dim].iter().any(|&x| !(x.is_finite() && x > 0.0)) {
            return Err(format!(
                "{key}: box size {size:?}: give positive edge lengths"
            ));
        }
        Geometry::cuboid(dim, size)
    } else if let Some(b) = sh.get("cylinder") {
        if dim != 3 {
            return Err(format!(
                "{key}: a cylinder is 3D; use a sphere (a disk) or a box in 2D"
            ));
        }
        Geometry::cylinder(
            pos(field(b, "radius", key)?, "radius")?,
            pos(field(b, "length", key)?, "length")?,
            axis_or_z(b)?,
        )
    } else if let Some(b) = sh.get("capsule") {
        Geometry::capsule(
            dim,
            pos(field(b, "radius", key)?, "radius")?,
            pos(field(b, "length", key)?, "length")?,
            axis_or_z(b)?,
        )
    } else if let Some(b) = sh.get("halfspace") {
        let n = point(field(b, "normal", key)?, key)?;
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if !(len.is_finite() && len > 0.0) {
            return Err(format!(
                "{key}: halfspace normal {n:?}: give a non-zero vector"
            ));
        }
        Geometry::halfspace(dim, n)
    } else {
        return Err(format!("{key}: give the shape as {{\"sphere\": {{radius}}}}, {{\"box\": {{size}}}}, {{\"cylinder\": {{radius, length, axis}}}}, {{\"capsule\": {{...}}}} or {{\"halfspace\": {{normal}}}}"));
    };
    Ok(geometry)
}

/// A rigid body's motion: kinematic at `velocity`, or dynamic with its mass (given, or from
/// its density and `geometry`).
fn rigid_motion(
    a: &Value,
    key: &str,
    geometry: &Geometry,
    velocity: [Real; 3],
    thickness: Real,
) -> R<Motion> {
    let pos = |v: &Value, what: &str| positive(v, &format!("{key}: {what}"));
    let (mass, density) = (a.get("mass"), a.get("density"));
    let motion = match a.get("motion").and_then(Value::as_str).unwrap_or("dynamic") {
        "kinematic" => {
            if mass.is_some() || density.is_some() {
                return Err(format!(
                    "{key}: a kinematic body moves as prescribed: remove mass and density"
                ));
            }
            Motion::Kinematic(velocity.map(TimeFunction::Constant))
        }
        "dynamic" => {
            if geometry.is_unbounded() {
                return Err(format!(
                    "{key}: a half-space has no finite mass: make it motion = \"kinematic\""
                ));
            }
            let mass = match (mass, density) {
                (Some(m), None) => pos(m, "mass")?,
                (None, Some(d)) => geometry.mass(pos(d, "density")?, thickness),
                (Some(_), Some(_)) => return Err(format!("{key}: give mass or density, not both")),
                (None, None) => {
                    return Err(format!(
                        "{key}: a dynamic body needs its mass (kg) or density (kg/m^3)"
                    ))
                }
            };
            Motion::Dynamic { mass }
        }
        other => {
            return Err(format!(
                "{key}: motion \"{other}\": give \"dynamic\" or \"kinematic\""
            ))
        }
    };
    Ok(motion)
}

/// `{"modulus": m, "seed": s}`: a Weibull scatter (checked by the library).
fn weibull(a: &Value, key: &str) -> R<hooke_sim::Weibull> {
    let seed = a.get("seed").and_then(Value::as_u64).unwrap_or(0);
    hooke_sim::Weibull::new(num(field(a, "modulus", key)?, key)?, seed)
        .map_err(|e| format!("{key}: {e}"))
}

/// A critical stretch or a fracture energy, if given (not both).
fn toughness(a: &Value, key: &str) -> R<Option<hooke_sim::Toughness>> {
    match (
        optional_num(a, "critical_stretch", key)?,
        optional_num(a, "fracture_energy", key)?,
    ) {
        (None, None) => Ok(None),
        (Some(s), None) => Ok(Some(hooke_sim::Toughness::Stretch(s))),
        (None, Some(g)) => Ok(Some(hooke_sim::Toughness::Energy(g))),
        _ => Err(format!(
            "{key}: give critical_stretch or fracture_energy, not both"
        )),
    }
}

/// The material of a `phase` or `inclusions` call: name, constants, own strength, scatter.
fn phase_material(a: &Value, key: &str) -> R<hooke_sim::PhaseMaterial> {
    let name = field(a, "name", key)?
        .as_str()
        .ok_or_else(|| format!("{key}: name: give the material's name"))?;
    let mut m = hooke_sim::PhaseMaterial::new(
        name,
        num(field(a, "youngs", key)?, key)?,
        num(field(a, "poisson", key)?, key)?,
        num(field(a, "density", key)?, key)?,
    );
    m.toughness = toughness(a, key)?;
    if let Some(w) = a.get("weibull").filter(|w| !w.is_null()) {
        m.weibull = Some(weibull(w, key)?);
    }
    Ok(m)
}

/// The `inclusions` call's grading, sizes, fraction, gap and seed.
fn inclusion_spec(a: &Value, key: &str) -> R<hooke_sim::inclusions::InclusionSpec> {
    use hooke_sim::inclusions::Grading;
    let grading = match a.get("grading").and_then(Value::as_str).unwrap_or("fuller") {
        "fuller" => Grading::Fuller {
            exponent: optional_num(a, "fuller_exponent", key)?.unwrap_or(0.5),
        },
        "uniform" => Grading::Uniform,
        other => {
            return Err(format!(
                "{key}: grading \"{other}\": give \"fuller\" or \"uniform\""
            ))
        }
    };
    Ok(hooke_sim::inclusions::InclusionSpec {
        grading,
        d_min: num(field(a, "d_min", key)?, key)?,
        d_max: num(field(a, "d_max", key)?, key)?,
        fraction: num(field(a, "fraction", key)?, key)?,
        gap: optional_num(a, "gap", key)?.unwrap_or(0.0),
        seed: a.get("seed").and_then(Value::as_u64).unwrap_or(0),
    })
}

/// The `interface` call: two material names, own strength, stiffness factor.
fn interface(a: &Value, key: &str) -> R<hooke_sim::Interface> {
    let between: Vec<String> = field(a, "between", key)?
        .as_array()
        .map(|v| {
            v.iter()
                .filter_map(|s| s.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    let [x, y] = between.as_slice() else {
        return Err(format!("{key}: between: give two material names"));
    };
    Ok(hooke_sim::Interface {
        between: [x.clone(), y.clone()],
        toughness: toughness(a, key)?,
        stiffness: optional_num(a, "stiffness_factor", key)?.unwrap_or(1.0),
    })
}

/// The `transverse` call's material.
fn transverse(a: &Value, key: &str) -> R<hooke_core::Transverse> {
    let fibre = point(field(a, "fibre", key)?, key)?;
    Ok(hooke_core::Transverse {
        youngs_plane: num(field(a, "youngs_plane", key)?, key)?,
        youngs_fibre: num(field(a, "youngs_fibre", key)?, key)?,
        poisson_plane: num(field(a, "poisson_plane", key)?, key)?,
        poisson_fibre: num(field(a, "poisson_fibre", key)?, key)?,
        shear_fibre: num(field(a, "shear_fibre", key)?, key)?,
        density: num(field(a, "density", key)?, key)?,
        fibre,
    })
}

/// A pre-crack: `precrack_segment` (2D, from `a` to `b`) or `precrack_polygon` (3D, its
/// vertices).
fn precrack(name: &str, a: &Value, key: &str) -> R<Crack> {
    if name == "precrack_segment" {
        let (p, q) = (
            point(field(a, "a", key)?, key)?,
            point(field(a, "b", key)?, key)?,
        );
        return Ok(Crack::Segment {
            a: [p[0], p[1]],
            b: [q[0], q[1]],
        });
    }
    let vertices = a
        .as_array()
        .ok_or_else(|| format!("{key}: give a list of [x, y, z] vertices"))?
        .iter()
        .map(|v| point(v, key))
        .collect::<R<Vec<_>>>()?;
    Ok(Crack::Polygon { vertices })
}

/// An optional number `name` of `a` (absent or null: none).
fn optional_num(a: &Value, name: &str, key: &str) -> R<Option<Real>> {
    match a.get(name) {
        None | Some(Value::Null) => Ok(None),
        Some(g) => Ok(Some(num(g, key)?)),
    }
}

/// The `orthotropic` call's material.
fn orthotropic(a: &Value, key: &str) -> R<hooke_core::Orthotropic> {
    let three = |name: &str| -> R<[Real; 3]> {
        let v = field(a, name, key)?;
        let arr = v
            .as_array()
            .filter(|x| x.len() == 3)
            .ok_or_else(|| format!("{key}: {name}: give three numbers, not {v}"))?;
        Ok([num(&arr[0], key)?, num(&arr[1], key)?, num(&arr[2], key)?])
    };
    let axes = match a.get("axes").filter(|v| !v.is_null()) {
        None => hooke_core::Orthotropic::AXES,
        Some(v) => {
            let pair = v.as_array().filter(|p| p.len() == 2).ok_or_else(|| {
                format!("{key}: axes: give the material x and y axes, two directions, not {v}")
            })?;
            hooke_core::Orthotropic::axes_from(point(&pair[0], key)?, point(&pair[1], key)?)
                .map_err(|e| format!("{key}: axes: {e}"))?
        }
    };
    Ok(hooke_core::Orthotropic {
        youngs: three("youngs")?,
        poisson: three("poisson")?,
        shear: three("shear")?,
        density: num(field(a, "density", key)?, key)?,
        axes,
    })
}

/// The `boundary` call's boundary condition.
fn boundary(a: &Value, key: &str) -> R<Bc> {
    let mut bc = Bc::on(region(field(a, "region", key)?, key)?);
    if let Some(Value::Array(ax)) = a.get("fixed") {
        for x in ax {
            bc = bc.fixed(axis(x, key)?);
        }
    }
    for (what, f) in [("velocity", 0), ("displacement", 1)] {
        if let Some(Value::Object(m)) = a.get(what) {
            for (ax, tf) in m {
                let (ax, tf) = (
                    axis(&Value::from(ax.as_str()), key)?,
                    time_function(tf, key)?,
                );
                bc = if f == 0 {
                    bc.velocity(ax, tf)
                } else {
                    bc.displacement(ax, tf)
                };
            }
        }
    }
    if let Some(t) = a.get("traction") {
        let v = point(field(t, "value", key)?, key)?;
        let normal = axis(field(t, "normal", key)?, key)?;
        let scale = match t.get("scale") {
            Some(f) => time_function(f, key)?,
            None => TimeFunction::Constant(1.0),
        };
        bc = bc.traction(v, normal, scale);
    }
    if a.get("no_fail").and_then(Value::as_bool) == Some(true) {
        bc = bc.no_fail();
    }
    if let Some(n) = a.get("name").and_then(Value::as_str) {
        bc = bc.named(n);
    }
    Ok(bc)
}

/// The `random` call's seed and sampler.
fn random_spec(a: &Value, key: &str) -> R<RandomSpec> {
    let seed = match a.get("seed") {
        None => 1,
        Some(s) => s
            .as_u64()
            .ok_or_else(|| format!("{key}: give a non-negative integer seed"))?,
    };
    let sampler = match a
        .get("sampler")
        .and_then(Value::as_str)
        .unwrap_or("poisson")
    {
        "poisson" => Sampler::Poisson,
        "jitter" => {
            let j = a
                .get("jitter")
                .map(|j| num(j, key))
                .transpose()?
                .unwrap_or(0.6);
            if !(0.0..=1.0).contains(&j) {
                return Err(format!(
                    "{key}: jitter {j}: give the largest move as a fraction of the spacing, 0 to 1"
                ));
            }
            Sampler::Jitter { amplitude: j }
        }
        other => {
            return Err(format!(
                "{key}: unknown sampler \"{other}\"; use \"poisson\" or \"jitter\""
            ))
        }
    };
    Ok(RandomSpec { sampler, seed })
}

/// The `breaking` call's rule: a critical stretch or a fracture energy, for the stretch or
/// the energy criterion.
fn breaking_rule(a: &Value, key: &str) -> R<BreakRule> {
    let energy = match a
        .get("criterion")
        .and_then(Value::as_str)
        .unwrap_or("stretch")
    {
        "stretch" => false,
        "energy" => true,
        other => {
            return Err(format!(
                "{key}: criterion \"{other}\": give \"stretch\" or \"energy\""
            ))
        }
    };
    let fibre = a.get("stretch_fibre").filter(|v| !v.is_null());
    let rule = match (a.get("stretch"), a.get("fracture_energy"), energy, fibre) {
        (Some(s), None, false, Some(f)) => BreakRule::FibreStretch {
            across: num(s, key)?,
            along: num(f, key)?,
        },
        (_, _, _, Some(_)) => {
            return Err(format!(
            "{key}: stretch_fibre goes with stretch (across the fibre) and the stretch criterion"
        ))
        }
        _ => match (a.get("stretch"), a.get("fracture_energy"), energy) {
            (Some(s), None, false) => BreakRule::Stretch(num(s, key)?),
            (Some(s), None, true) => BreakRule::SpringEnergyFromStretch(num(s, key)?),
            (None, Some(g), false) => BreakRule::FractureEnergy(num(g, key)?),
            (None, Some(g), true) => BreakRule::SpringEnergy(num(g, key)?),
            _ => return Err(format!("{key}: give stretch or fracture_energy")),
        },
    };
    Ok(rule)
}

/// The `softening` call's rule.
fn softening_rule(a: &Value, key: &str) -> R<BreakRule> {
    let shape = match a.get("shape").and_then(Value::as_str).unwrap_or("linear") {
        "linear" => SofteningShape::Linear,
        "bilinear" => SofteningShape::Bilinear,
        other => {
            return Err(format!(
                "{key}: shape \"{other}\": give \"linear\" or \"bilinear\""
            ))
        }
    };
    let get = |k: &str| a.get(k).filter(|v| !v.is_null());
    let rule = match (
        get("fracture_energy"),
        get("tensile_strength"),
        get("characteristic_length"),
        get("peak_stretch"),
        get("final_stretch"),
    ) {
        (Some(g), Some(f), None, None, None) => BreakRule::Softening {
            fracture_energy: num(g, key)?,
            strength: Strength::Tensile(num(f, key)?),
            shape,
        },
        (Some(g), None, Some(l), None, None) => BreakRule::Softening {
            fracture_energy: num(g, key)?,
            strength: Strength::CharacteristicLength(num(l, key)?),
            shape,
        },
        (None, None, None, Some(p), Some(f)) => BreakRule::SofteningStretch {
            peak: num(p, key)?,
            last: num(f, key)?,
            shape,
        },
        _ => {
            return Err(format!(
                "{key}: give fracture_energy with tensile_strength or \
                 characteristic_length, or peak_stretch with final_stretch"
            ))
        }
    };
    Ok(rule)
}

/// The `time_step` call: a safety factor on the stable step, or a fixed step.
fn time_step(a: &Value, key: &str) -> R<TimeStep> {
    Ok(match (a.get("safety"), a.get("dt")) {
        (Some(s), None) => TimeStep::Auto {
            safety: num(s, key)?,
        },
        (None, Some(dt)) => TimeStep::Fixed {
            dt: num(dt, key)?,
            force: a.get("force").and_then(Value::as_bool).unwrap_or(false),
        },
        _ => return Err(format!("{key}: give safety or dt")),
    })
}

/// A simulation under construction in Python: `hooke.Builder`'s calls applied one by one to
/// `hooke_sim::Builder` as they come (a mistake raises at the call that made it), with what the
/// library's builder takes at the end (the solid, the rigid bodies and the contact options).
#[derive(Clone, Debug)]
pub struct Pending {
    b: Builder,
    solid: Solid,
    dim: usize,
    thickness: Real,
    rigids: Vec<RigidSpec>,
    contact: Option<ContactSpec>,
    /// Calls applied so far (a mistake's message counts them, as the user wrote them).
    calls: usize,
}

impl Pending {
    /// A body of `lattice` ("cubic", "hex", "random2d", "random3d") with `spacing` (m).
    pub fn new(lattice: &str, spacing: Real) -> R<Pending> {
        let kind = match lattice {
            "cubic" => LatticeKind::Cubic,
            "hex" => LatticeKind::Hex,
            "random2d" => LatticeKind::Random2d,
            "random3d" => LatticeKind::Random3d,
            _ => {
                return Err(format!(
                    "lattice \"{lattice}\": give \"cubic\", \"hex\", \"random2d\" or \"random3d\""
                ))
            }
        };
        Ok(Pending {
            b: Builder::new(kind, spacing),
            solid: Solid::default(),
            dim: kind.dim(),
            thickness: 1.0,
            rigids: Vec::new(),
            contact: None,
            calls: 0,
        })
    }

    /// Apply the call `name` with its argument `a` (the Python method's, as plain data). On a
    /// mistake nothing changes and the message names the call.
    pub fn apply(&mut self, name: &str, a: &Value) -> R<()> {
        let key = format!("{name} (call {})", self.calls + 1);
        let key = key.as_str();
        let b = self.b.clone();
        self.b = match name {
            "thickness" => {
                self.thickness = num(a, key)?;
                b.thickness(self.thickness)
            }
            "plane" => b.plane(match a.as_str() {
                Some("stress") => PlaneModel::Stress,
                Some("strain") => PlaneModel::Strain,
                _ => return Err(format!("{key}: give \"stress\" or \"strain\"")),
            }),
            "box" => {
                self.solid.bbox = Some((
                    Vector::from(point(field(a, "min", key)?, key)?),
                    Vector::from(point(field(a, "max", key)?, key)?),
                ));
                b
            }
            "add" => {
                self.solid.add.push(shape(a, key)?);
                b
            }
            "subtract" => {
                self.solid.subtract.push(shape(a, key)?);
                b
            }
            "material" => b.material(
                num(field(a, "youngs", key)?, key)?,
                num(field(a, "poisson", key)?, key)?,
                num(field(a, "density", key)?, key)?,
            ),
            "material_name" => {
                b.material_name(a.as_str().ok_or_else(|| format!("{key}: give a name"))?)
            }
            "weibull" => b.weibull(weibull(a, key)?),
            "phase" => b.phase_of(
                shape(field(a, "shape", key)?, key)?,
                phase_material(a, key)?,
            ),
            "inclusions" => b.inclusions(inclusion_spec(a, key)?, phase_material(a, key)?),
            "interface" => b.interface(interface(a, key)?),
            "transverse" => b.transverse(transverse(a, key)?),
            "orthotropic" => b.orthotropic(orthotropic(a, key)?),
            "rotate_lattice" => b.rotate_lattice(point(a, key)?),
            "cell_weights" => b.cell_weights(
                a.as_bool()
                    .ok_or_else(|| format!("{key}: give true or false"))?,
            ),
            "fracture_energy" => b.fracture_energy(num(a, key)?),
            "precrack_segment" | "precrack_polygon" => b.precrack(precrack(name, a, key)?),
            "boundary" => b.boundary(boundary(a, key)?),
            "initial_velocity" => b.initial_velocity(
                region(field(a, "region", key)?, key)?,
                point(field(a, "velocity", key)?, key)?,
            ),
            "gravity" => b.body_acceleration(point(a, key)?),
            "end_time" => b.end_time(num(a, key)?),
            "output_every" => b.output_every(num(a, key)?),
            "checkpoint_every" => b.checkpoint_every(num(a, key)?),
            "damping" => b.damping(num(a, key)?),
            "reactions_every" => b.reactions_every(num(a, key)?),
            "springs" => b.springs(
                a.as_bool()
                    .ok_or_else(|| format!("{key}: give true or false"))?,
            ),
            "formats" => {
                let flag = |n: &str| a.get(n).and_then(Value::as_bool).unwrap_or(n == "vtk");
                b.formats(flag("vtk"), flag("hdf5"))
            }
            "quasi_static" => b.quasi_static(
                a.as_u64()
                    .filter(|&n| n > 0)
                    .ok_or_else(|| format!("{key}: give a positive number of load steps"))?
                    as usize,
            ),
            "time_step" => b.time_step(time_step(a, key)?),
            "random" => b.random(random_spec(a, key)?),
            "breaking" => b.breaking(breaking_rule(a, key)?),
            "softening" => b.breaking(softening_rule(a, key)?),
            "rigid" => {
                let body = rigid(a, key, self.dim, self.thickness, self.rigids.len())?;
                let start_gap = optional_num(a, "start_gap", key)?;
                self.rigids.push(RigidSpec { body, start_gap });
                b
            }
            "contact" => {
                self.contact = Some(contact_spec(a)?);
                b
            }
            other => return Err(format!("{key}: unknown call \"{other}\"")),
        };
        self.calls += 1;
        Ok(())
    }

    /// The simulation (the builder stays as it was: it can build again).
    pub fn build(&self) -> R<Simulation> {
        let p = self.clone();
        let b = if p.contact.is_some() || !p.rigids.is_empty() {
            p.b.contact(p.contact.unwrap_or_default(), p.rigids)
        } else {
            p.b
        };
        b.solid(p.solid).build().map_err(|e| e.to_string())
    }
}

/// Contact options as `[contact]` (checked against the body by the library's builder).
fn contact_spec(c: &Value) -> R<ContactSpec> {
    let key = "contact";
    let opt = |name: &str| -> R<Option<Real>> {
        match c.get(name) {
            None | Some(Value::Null) => Ok(None),
            Some(v) => Ok(Some(num(v, key)?)),
        }
    };
    Ok(ContactSpec {
        stiffness_factor: opt("stiffness_factor")?,
        radius: opt("radius")?,
        fragments: c.get("fragments").and_then(Value::as_bool),
        fragment_distance: opt("fragment_distance")?,
    })
}
