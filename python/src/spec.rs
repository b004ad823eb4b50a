//! A simulation built in Python: the Python `hooke.Builder` collects its calls into a JSON
//! spec, and this module replays them on `hooke_sim::Builder`. Keeping the spec as plain data
//! leaves the binding thin: every check and every error message is the library's
//! (`BuildError` names the item), except the spec's own shape, checked here with the key.

use hooke_core::loading::TimeFunction;
use hooke_core::{LatticeKind, PlaneModel, Real, Vector};
use hooke_fracture::Crack;
use hooke_sim::{Bc, Builder, Region, Shape, Simulation, Solid};
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

/// Build the simulation a `hooke.Builder` spec describes.
pub fn build(spec: &Value) -> R<Simulation> {
    let kind = match field(spec, "lattice", "lattice")?.as_str() {
        Some("cubic") => LatticeKind::Cubic,
        Some("hex") => LatticeKind::Hex,
        Some("random2d") => LatticeKind::Random2d,
        Some("random3d") => LatticeKind::Random3d,
        _ => return Err("lattice: give \"cubic\", \"hex\", \"random2d\" or \"random3d\"".into()),
    };
    let mut b = Builder::new(kind, num(field(spec, "spacing", "spacing")?, "spacing")?);
    let calls = field(spec, "calls", "calls")?
        .as_array()
        .ok_or("calls: a list")?;
    let mut solid = Solid::default();
    for (k, call) in calls.iter().enumerate() {
        let name = call.get(0).and_then(Value::as_str).unwrap_or("");
        let a = call.get(1).cloned().unwrap_or(Value::Null);
        let key = format!("{name} (call {})", k + 1);
        let key = key.as_str();
        b = match name {
            "thickness" => b.thickness(num(&a, key)?),
            "plane" => b.plane(match a.as_str() {
                Some("stress") => PlaneModel::Stress,
                Some("strain") => PlaneModel::Strain,
                _ => return Err(format!("{key}: give \"stress\" or \"strain\"")),
            }),
            "box" => {
                solid.bbox = Some((
                    Vector::from(point(field(&a, "min", key)?, key)?),
                    Vector::from(point(field(&a, "max", key)?, key)?),
                ));
                b
            }
            "add" => {
                solid.add.push(shape(&a, key)?);
                b
            }
            "subtract" => {
                solid.subtract.push(shape(&a, key)?);
                b
            }
            "material" => b.material(
                num(field(&a, "youngs", key)?, key)?,
                num(field(&a, "poisson", key)?, key)?,
                num(field(&a, "density", key)?, key)?,
            ),
            "fracture_energy" => b.fracture_energy(num(&a, key)?),
            "precrack_segment" => {
                let (p, q) = (
                    point(field(&a, "a", key)?, key)?,
                    point(field(&a, "b", key)?, key)?,
                );
                b.precrack(Crack::Segment {
                    a: [p[0], p[1]],
                    b: [q[0], q[1]],
                })
            }
            "precrack_polygon" => {
                let vs = a
                    .as_array()
                    .ok_or_else(|| format!("{key}: give a list of [x, y, z] vertices"))?
                    .iter()
                    .map(|v| point(v, key))
                    .collect::<R<Vec<_>>>()?;
                b.precrack(Crack::Polygon { vertices: vs })
            }
            "boundary" => {
                let mut bc = Bc::on(region(field(&a, "region", key)?, key)?);
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
                if a.get("no_fail").and_then(Value::as_bool) == Some(true) {
                    bc = bc.no_fail();
                }
                if let Some(n) = a.get("name").and_then(Value::as_str) {
                    bc = bc.named(n);
                }
                b.boundary(bc)
            }
            "initial_velocity" => b.initial_velocity(
                region(field(&a, "region", key)?, key)?,
                point(field(&a, "velocity", key)?, key)?,
            ),
            "gravity" => b.body_acceleration(point(&a, key)?),
            "end_time" => b.end_time(num(&a, key)?),
            "output_every" => b.output_every(num(&a, key)?),
            "checkpoint_every" => b.checkpoint_every(num(&a, key)?),
            "damping" => b.damping(num(&a, key)?),
            other => return Err(format!("{key}: unknown call \"{other}\"")),
        };
    }
    b.solid(solid).build().map_err(|e| e.to_string())
}
