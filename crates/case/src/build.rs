//! Validation and building.

use std::ops::Range;
use std::path::{Path, PathBuf};

use hooke_contact::{Geometry, MeshShape, RigidBody};
use hooke_core::dynamics::TimeStep;
use hooke_core::loading::TimeFunction;
use hooke_core::material::PlaneModel;
use hooke_core::random::{RandomSpec, Sampler};
use hooke_core::{LatticeKind, Real, Vector};
use hooke_fracture::{Crack, SofteningShape};
use hooke_sim::geometry::{Face, Region, Shape, Solid};
use hooke_sim::{
    Bc, BreakRule, BuildError, Builder, ContactSpec, Interface, PhaseMaterial, RigidSpec, Strength,
    Toughness, Weibull,
};
use toml::Spanned;

use crate::error::{line_col, CaseError};
use crate::schema::*;

pub use hooke_sim::Simulation;

struct Ctx<'a> {
    file: &'a Path,
    text: &'a str,
}

impl Ctx<'_> {
    fn err(
        &self,
        span: Range<usize>,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> CaseError {
        let (line, column) = line_col(self.text, span.start);
        CaseError {
            file: self.file.to_path_buf(),
            line,
            column,
            key: key.into(),
            message: message.into(),
        }
    }

    fn positive(&self, v: &Spanned<Real>, key: &str, unit: &str) -> Result<Real, CaseError> {
        let x = *v.get_ref();
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(
                v.span(),
                key,
                format!("{x} is not a positive number; give a positive value in {unit}"),
            ))
        }
    }

    fn point(&self, v: &Spanned<Vec<Real>>, key: &str, dim: usize) -> Result<Vector, CaseError> {
        let p = v.get_ref();
        if !(p.len() == dim || (dim == 2 && p.len() == 3)) || !p.iter().all(|x| x.is_finite()) {
            return Err(self.err(
                v.span(),
                key,
                format!(
                    "expected {dim} finite coordinates in m, e.g. {}",
                    if dim == 3 {
                        "[0.0, 0.0, 0.0]"
                    } else {
                        "[0.0, 0.0]"
                    }
                ),
            ));
        }
        Ok(Vector::new(
            p[0],
            p[1],
            if p.len() > 2 { p[2] } else { 0.0 },
        ))
    }
}

fn axis_index(ctx: &Ctx, a: &Spanned<String>, key: &str, dim: usize) -> Result<usize, CaseError> {
    match (a.get_ref().as_str(), dim) {
        ("x", _) => Ok(0),
        ("y", _) => Ok(1),
        ("z", 3) => Ok(2),
        (other, _) => Err(ctx.err(
            a.span(),
            key,
            format!(
                "unknown axis \"{other}\"; use \"x\", \"y\"{}",
                if dim == 3 {
                    " or \"z\""
                } else {
                    " (the lattice is 2D)"
                }
            ),
        )),
    }
}

/// How a random lattice scatters its nodes (`lattice.sampler`, `jitter`, `seed`); refused on
/// regular lattices.
fn random_spec(ctx: &Ctx, l: &RawLattice, kind: LatticeKind) -> Result<RandomSpec, CaseError> {
    if !kind.is_random() {
        for (present, key) in [
            (l.sampler.as_ref().map(|v| v.span()), "lattice.sampler"),
            (l.jitter.as_ref().map(|v| v.span()), "lattice.jitter"),
            (l.seed.as_ref().map(|v| v.span()), "lattice.seed"),
        ] {
            if let Some(span) = present {
                return Err(ctx.err(
                    span,
                    key,
                    "only random lattices (random2d, random3d) take this key; remove it",
                ));
            }
        }
        return Ok(RandomSpec::default());
    }
    let seed = match &l.seed {
        None => 1,
        Some(s) if *s.get_ref() >= 0 => *s.get_ref() as u64,
        Some(s) => {
            return Err(ctx.err(s.span(), "lattice.seed", "give a non-negative integer seed"))
        }
    };
    let amplitude = match &l.jitter {
        None => 0.6,
        Some(j) => {
            let v = *j.get_ref();
            if !(0.0..=1.0).contains(&v) {
                return Err(ctx.err(
                    j.span(),
                    "lattice.jitter",
                    format!("{v}: give the largest move as a fraction of the spacing, 0 to 1"),
                ));
            }
            v
        }
    };
    let sampler = match l.sampler.as_ref().map(|s| (s.get_ref().as_str(), s.span())) {
        None | Some(("poisson", _)) => {
            if let Some(j) = &l.jitter {
                return Err(ctx.err(
                    j.span(),
                    "lattice.jitter",
                    "jitter applies to sampler = \"jitter\"; remove it or set the sampler",
                ));
            }
            Sampler::Poisson
        }
        Some(("jitter", _)) => Sampler::Jitter { amplitude },
        Some((other, span)) => {
            return Err(ctx.err(
                span,
                "lattice.sampler",
                format!("unknown sampler \"{other}\"; use \"poisson\" or \"jitter\""),
            ))
        }
    };
    Ok(RandomSpec { sampler, seed })
}

/// A mesh file named by a case (`key.mesh`), beside the case file, scaled to metres.
fn load_mesh(ctx: &Ctx, m: &RawMesh, key: &str) -> Result<MeshShape, CaseError> {
    let scale = match &m.scale {
        Some(v) => ctx.positive(v, &format!("{key}.mesh.scale"), "(m per file unit)")?,
        None => 1.0,
    };
    let base = ctx.file.parent().unwrap_or(Path::new("."));
    MeshShape::load(&base.join(m.file.get_ref()), scale)
        .map_err(|e| ctx.err(m.file.span(), format!("{key}.mesh.file"), e.to_string()))
}

/// A closed triangle mesh (STL or OBJ, beside the case file) bounding a 3D body.
fn mesh_shape(ctx: &Ctx, m: &RawMesh, key: &str, dim: usize) -> Result<Shape, CaseError> {
    if dim != 3 {
        return Err(ctx.err(
            m.file.span(),
            format!("{key}.mesh"),
            "a triangle mesh bounds a 3D body; 2D bodies take a polygon",
        ));
    }
    let mesh = load_mesh(ctx, m, key)?;
    Ok(Shape::Mesh(std::sync::Arc::new(mesh)))
}

/// A polygon in the x-y plane (extruded along z in a 3D body).
fn polygon_shape(ctx: &Ctx, p: &RawPolygon, key: &str, dim: usize) -> Result<Shape, CaseError> {
    let pts = p.points.get_ref();
    if pts.len() < 3
        || pts
            .iter()
            .any(|q| q.len() != 2 || !q.iter().all(|v| v.is_finite()))
    {
        return Err(ctx.err(
            p.points.span(),
            format!("{key}.points"),
            "a polygon is three or more points [x, y] in the x-y plane, in order",
        ));
    }
    let z = match (&p.z, dim) {
        (Some(z), 3) => {
            let v = z.get_ref();
            if v.len() != 2 || !(v[1] > v[0]) {
                return Err(ctx.err(
                    z.span(),
                    format!("{key}.z"),
                    "give the extrusion as z = [z0, z1] with z1 > z0",
                ));
            }
            Some((v[0], v[1]))
        }
        (None, 3) => {
            return Err(ctx.err(
                p.points.span(),
                format!("{key}.z"),
                "a polygon in a 3D body needs its extrusion z = [z0, z1]",
            ))
        }
        (Some(z), _) => {
            return Err(ctx.err(
                z.span(),
                format!("{key}.z"),
                "2D bodies take no extrusion; remove z",
            ))
        }
        (None, _) => None,
    };
    Ok(Shape::Polygon {
        pts: pts.iter().map(|q| (q[0], q[1])).collect(),
        z,
    })
}

fn shape(ctx: &Ctx, sh: &Spanned<RawShape>, key: &str, dim: usize) -> Result<Shape, CaseError> {
    let s = sh.get_ref();
    let given = [
        s.bbox.is_some(),
        s.sphere.is_some(),
        s.circle.is_some(),
        s.cylinder.is_some(),
        s.polygon.is_some(),
        s.mesh.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if given != 1 {
        return Err(ctx.err(
            sh.span(),
            key,
            "give exactly one of box, sphere (circle in 2D), cylinder, polygon or mesh",
        ));
    }
    if let Some(m) = &s.mesh {
        return mesh_shape(ctx, m, key, dim);
    }
    if let Some(b) = &s.bbox {
        let (lo, hi) = (
            ctx.point(&b.min, &format!("{key}.box.min"), dim)?,
            ctx.point(&b.max, &format!("{key}.box.max"), dim)?,
        );
        if (0..dim).any(|c| hi[c] <= lo[c]) {
            return Err(ctx.err(
                b.max.span(),
                key,
                "the box is empty: every max coordinate must exceed its min",
            ));
        }
        return Ok(Shape::Box { lo, hi });
    }
    if let Some(b) = s.sphere.as_ref().or(s.circle.as_ref()) {
        return Ok(Shape::Ball {
            c: ctx.point(&b.center, &format!("{key}.center"), dim)?,
            r: ctx.positive(&b.radius, &format!("{key}.radius"), "m")?,
        });
    }
    if let Some(c) = &s.cylinder {
        let axis = axis_index(ctx, &c.axis, &format!("{key}.axis"), 3)?;
        return Ok(Shape::Cylinder {
            c: ctx.point(&c.center, &format!("{key}.center"), dim)?,
            axis,
            r: ctx.positive(&c.radius, &format!("{key}.radius"), "m")?,
            half: 0.5 * ctx.positive(&c.length, &format!("{key}.length"), "m")?,
        });
    }
    polygon_shape(
        ctx,
        s.polygon.as_ref().expect("one shape is given"),
        key,
        dim,
    )
}

/// Where each key handed to the builder stands in the file, so that the builder's errors (which
/// name the key) point at the line that set it.
#[derive(Default)]
struct Spans(Vec<(String, Range<usize>)>);

impl Spans {
    fn at(&mut self, key: impl Into<String>, span: Range<usize>) {
        self.0.push((key.into(), span));
    }

    /// The builder's error at the key's span, or its nearest enclosing key's.
    fn error(&self, ctx: &Ctx, e: BuildError) -> CaseError {
        let mut k = e.key.as_str();
        loop {
            if let Some((_, s)) = self.0.iter().rev().find(|(key, _)| key == k) {
                return ctx.err(s.clone(), e.key, e.message);
            }
            match k.rfind(['.', '[']) {
                Some(i) => k = &k[..i],
                None => return ctx.err(0..0, e.key, e.message),
            }
        }
    }
}

/// Read, validate and build the case at `path`, with the lattice spacing divided by `scale`.
pub fn load(path: &Path, scale: Real) -> Result<Simulation, CaseError> {
    let text = std::fs::read_to_string(path).map_err(|e| CaseError {
        file: path.to_path_buf(),
        line: 0,
        column: 0,
        key: String::new(),
        message: format!("cannot read the case file: {e}"),
    })?;
    load_str(path, &text, scale)
}

/// As [`load_str`], with `--set` overrides applied to the text first; an error in an
/// overridden value names the override.
pub fn load_str_with(
    path: &Path,
    text: &str,
    scale: Real,
    overrides: &[crate::Override],
) -> Result<Simulation, CaseError> {
    load_parts(path, text, scale, overrides, None)
}

/// [`load_str_with`], the body set up from parts shared by `parts` if given
/// ([`hooke_sim::Builder::parts`]: each process builds and holds only its piece). Collective
/// then: every member of the team calls it with the same case.
pub fn load_parts(
    path: &Path,
    text: &str,
    scale: Real,
    overrides: &[crate::Override],
    parts: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
) -> Result<Simulation, CaseError> {
    if overrides.is_empty() {
        return load_str_in(path, text, scale, parts);
    }
    let edited = crate::overrides::apply(path, text, overrides)?;
    load_str_in(path, &edited.text, scale, parts).map_err(|e| edited.map_error(e))
}

/// As [`load`], from text (`path` only names the file in messages).
///
/// TOML -> the raw schema (`parse`) -> each section validated into the library's
/// [`Builder`] (`lattice`, `material`, `precracks`, `boundaries`, `schedule`) -> the built
/// simulation, then the rigid bodies and contact, which need the body.
pub fn load_str(path: &Path, text: &str, scale: Real) -> Result<Simulation, CaseError> {
    load_str_in(path, text, scale, None)
}

/// [`load_str`], from parts if `parts` is given ([`load_parts`]).
fn load_str_in(
    path: &Path,
    text: &str,
    scale: Real,
    parts: Option<std::sync::Arc<dyn hooke_core::team::Team>>,
) -> Result<Simulation, CaseError> {
    let file: PathBuf = path.to_path_buf();
    let ctx = Ctx { file: &file, text };
    if !(scale.is_finite() && scale > 0.0) {
        return Err(CaseError {
            file,
            line: 0,
            column: 0,
            key: "--scale".into(),
            message: format!("{scale}: give a positive factor (0.25 divides the resolution by 4)"),
        });
    }
    let raw = parse(&ctx)?;
    let mut spans = Spans::default();
    let (builder, kind, h) = lattice(&ctx, &raw, scale, &mut spans)?;
    let builder = material(&ctx, &raw, kind, builder, &mut spans)?;
    let builder = precracks(&ctx, &raw, kind.dim(), builder, &mut spans)?;
    let builder = boundaries(&ctx, &raw, kind.dim(), builder, &mut spans)?;
    let builder = schedule(&ctx, &raw, builder, &mut spans)?;
    let builder = contact(&ctx, &raw, kind.dim(), h, builder, &mut spans)?;
    let builder = match parts {
        Some(team) => builder.parts(team),
        None => builder,
    };
    builder.build().map_err(|e| spans.error(&ctx, e))
}

/// The softening springs' keys, in a material without `criterion = "softening"`: mistakes.
fn refuse_softening_keys(ctx: &Ctx, m: &RawMaterial) -> Result<(), CaseError> {
    for (key, span) in [
        ("material.softening", m.softening.as_ref().map(|v| v.span())),
        (
            "material.tensile_strength",
            m.tensile_strength.as_ref().map(|v| v.span()),
        ),
        (
            "material.characteristic_length",
            m.characteristic_length.as_ref().map(|v| v.span()),
        ),
        (
            "material.peak_stretch",
            m.peak_stretch.as_ref().map(|v| v.span()),
        ),
        (
            "material.final_stretch",
            m.final_stretch.as_ref().map(|v| v.span()),
        ),
    ] {
        if let Some(span) = span {
            return Err(ctx.err(
                span,
                key,
                "this key belongs to softening springs; add criterion = \"softening\" or remove it",
            ));
        }
    }
    Ok(())
}

/// `material.criterion`: whether it is the spring-energy criterion (`"energy"`, regular
/// lattices only) rather than the critical stretch itself (`"stretch"`, the default).
fn energy_criterion(
    ctx: &Ctx,
    m: &RawMaterial,
    kind: LatticeKind,
    spans: &mut Spans,
) -> Result<bool, CaseError> {
    // The criterion: the critical stretch itself, or the spring energy calibrated to the same
    // G_c (regular lattices only: see hooke_fracture::energy).
    Ok(match &m.criterion {
        None => false,
        Some(c) => {
            spans.at("material.criterion", c.span());
            match c.get_ref().as_str() {
                "stretch" => false,
                "energy" if kind.is_random() => {
                    return Err(ctx.err(
                        c.span(),
                        "material.criterion",
                        "the energy criterion is calibrated on the hex and cubic lattices (a \
                         random lattice's springs differ in stiffness); use \"stretch\" here",
                    ))
                }
                "energy" => true,
                other => {
                    return Err(ctx.err(
                        c.span(),
                        "material.criterion",
                        format!(
                            "unknown criterion \"{other}\"; use \"stretch\", \"energy\" or \"softening\""
                        ),
                    ))
                }
            }
        }
    })
}

/// `[material]`: the elastic constants and the breaking rule.
fn material(
    ctx: &Ctx,
    raw: &RawCase,
    kind: LatticeKind,
    b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    let m = &raw.material;
    spans.at("material.density", m.density.span());
    let mut b = elastic(ctx, m, b, spans)?;
    if let Some(name) = &m.name {
        spans.at("material.name", name.span());
        b = b.material_name(name.get_ref().clone());
    }
    if let Some(w) = &m.weibull {
        b = b.weibull(weibull(ctx, w, "material.weibull")?);
    }
    if let Some(f) = &m.stiffness_field {
        let r = f.get_ref();
        let key = "material.stiffness_field";
        spans.at(key, f.span());
        spans.at(format!("{key}.cov"), r.cov.span());
        spans.at(
            format!("{key}.correlation_length"),
            r.correlation_length.span(),
        );
        let seed = seed(ctx, &r.seed, key)?;
        b = b.stiffness_field(hooke_sim::field::StiffnessField {
            cov: *r.cov.get_ref(),
            correlation_length: *r.correlation_length.get_ref(),
            seed,
        });
    }
    let b = inclusions(ctx, raw, b, spans)?;
    let b = phases(ctx, raw, kind.dim(), b, spans)?;
    let b = interfaces(ctx, raw, b, spans)?;
    let softening = m
        .criterion
        .as_ref()
        .is_some_and(|c| c.get_ref() == "softening");
    if softening {
        if let Some(f) = &m.critical_stretch_fibre {
            return Err(ctx.err(
                f.span(),
                "material.critical_stretch_fibre",
                "goes with the stretch criterion, not softening springs; remove it",
            ));
        }
        return softening_rule(ctx, m, b, spans);
    }
    refuse_softening_keys(ctx, m)?;
    let given = match (&m.fracture_energy, &m.critical_stretch) {
        (Some(g), None) => {
            spans.at("material.fracture_energy", g.span());
            Some((true, ctx.positive(g, "material.fracture_energy", "J/m^2")?))
        }
        (None, Some(s)) => {
            spans.at("material.critical_stretch", s.span());
            Some((
                false,
                ctx.positive(s, "material.critical_stretch", "(dimensionless)")?,
            ))
        }
        (Some(g), Some(_)) => {
            return Err(ctx.err(
                g.span(),
                "material.fracture_energy",
                "give fracture_energy or critical_stretch, not both",
            ))
        }
        (None, None) => None,
    };
    let energy = energy_criterion(ctx, m, kind, spans)?;
    if let (Some(c), None) = (&m.criterion, &given) {
        return Err(ctx.err(
            c.span(),
            "material.criterion",
            "a criterion needs fracture_energy or critical_stretch; give one, or remove criterion",
        ));
    }
    if let Some(f) = &m.critical_stretch_fibre {
        spans.at("material.critical_stretch_fibre", f.span());
        let along = ctx.positive(f, "material.critical_stretch_fibre", "(dimensionless)")?;
        return match (given, energy) {
            (Some((false, across)), false) => {
                Ok(b.breaking(BreakRule::FibreStretch { across, along }))
            }
            _ => Err(ctx.err(
                f.span(),
                "material.critical_stretch_fibre",
                "goes with critical_stretch (the stretch across the fibre) and the stretch criterion; give critical_stretch, or remove it",
            )),
        };
    }
    Ok(match given {
        None => b,
        Some((true, g)) if energy => b.breaking(BreakRule::SpringEnergy(g)),
        Some((true, g)) => b.breaking(BreakRule::FractureEnergy(g)),
        Some((false, s)) if energy => b.breaking(BreakRule::SpringEnergyFromStretch(s)),
        Some((false, s)) => b.breaking(BreakRule::Stretch(s)),
    })
}

/// `material.axes` of an orthotropic material: the material x and y axes in the body (z their
/// cross product), or the body's axes.
fn material_axes(
    ctx: &Ctx,
    m: &RawMaterial,
    spans: &mut Spans,
) -> Result<[[Real; 3]; 3], CaseError> {
    Ok(match &m.axes {
        None => hooke_core::Orthotropic::AXES,
        Some(a) => {
            spans.at("material.axes", a.span());
            let bad = |why: String| ctx.err(a.span(), "material.axes", why);
            match a.get_ref().as_slice() {
                [x, y] if x.len() == 3 && y.len() == 3 => hooke_core::Orthotropic::axes_from(
                    [x[0], x[1], x[2]],
                    [y[0], y[1], y[2]],
                )
                .map_err(|e| bad(format!("{e}")))?,
                _ => {
                    return Err(bad(
                        "give the material x and y axes as two directions, e.g. axes = [[0.866, 0.5, 0], [-0.5, 0.866, 0]] (z is their cross product)".into(),
                    ))
                }
            }
        }
    })
}

/// `material.fibre` of a transversely isotropic material (required; `at` is where to point
/// when it is missing).
fn material_fibre(
    ctx: &Ctx,
    m: &RawMaterial,
    at: Range<usize>,
    spans: &mut Spans,
) -> Result<[Real; 3], CaseError> {
    Ok(match &m.fibre {
        None => {
            return Err(ctx.err(
                at,
                "material.fibre",
                "missing: give the fibre direction, e.g. fibre = [0, 0, 1] (along a lattice axis)",
            ))
        }
        Some(f) => {
            spans.at("material.fibre", f.span());
            match f.get_ref().as_slice() {
                &[x, y, z] => [x, y, z],
                _ => {
                    return Err(ctx.err(
                        f.span(),
                        "material.fibre",
                        "give three numbers, e.g. fibre = [0, 0, 1]",
                    ))
                }
            }
        }
    })
}

/// A material key's name and its value in the case, where given.
type MaterialKey<'a> = (&'a str, &'a Option<Spanned<Real>>);

/// `material.kind`: isotropic (the default), transverse or orthotropic.
fn material_kind(ctx: &Ctx, m: &RawMaterial, spans: &mut Spans) -> Result<&'static str, CaseError> {
    Ok(match &m.kind {
        None => "isotropic",
        Some(k) => {
            spans.at("material.kind", k.span());
            match k.get_ref().as_str() {
                "isotropic" => "isotropic",
                "transverse" => "transverse",
                "orthotropic" => "orthotropic",
                other => {
                    return Err(ctx.err(
                        k.span(),
                        "material.kind",
                        format!("unknown material kind \"{other}\"; use \"isotropic\", \"transverse\" or \"orthotropic\""),
                    ))
                }
            }
        }
    })
}

/// The keys of the material kinds other than `kind`, and axes or a fibre where the kind takes
/// none, are mistakes: the first one found is named, with the fix. `keys` are the isotropic,
/// transverse and orthotropic kinds' keys.
fn refuse_foreign_keys(
    ctx: &Ctx,
    m: &RawMaterial,
    kind: &str,
    keys: [&[MaterialKey<'_>]; 3],
) -> Result<(), CaseError> {
    let [isotropic, transverse, orthotropic] = keys;
    // Keys of the other kinds are mistakes: name them.
    let foreign: Vec<(&str, &Option<Spanned<Real>>, &str)> = isotropic
        .iter()
        .map(|&(k, v)| (k, v, "isotropic"))
        .chain(transverse.iter().map(|&(k, v)| (k, v, "transverse")))
        .chain(orthotropic.iter().map(|&(k, v)| (k, v, "orthotropic")))
        .filter(|&(_, _, owner)| owner != kind)
        .collect();
    for (key, v, owner) in foreign {
        if let Some(v) = v {
            return Err(ctx.err(
                v.span(),
                format!("material.{key}"),
                if owner == "isotropic" {
                    format!(
                        "{} {kind} material does not take {key}; remove it (or remove kind)",
                        if kind == "transverse" { "a" } else { "an" }
                    )
                } else {
                    format!(
                        "this key belongs to {owner} materials; add kind = \"{owner}\" or remove it"
                    )
                },
            ));
        }
    }
    if let (Some(a), false) = (&m.axes, kind == "orthotropic") {
        return Err(ctx.err(
            a.span(),
            "material.axes",
            "material axes belong to orthotropic materials (a transversely isotropic one takes a fibre); add kind = \"orthotropic\" or remove it",
        ));
    }
    if let (Some(f), false) = (&m.fibre, kind == "transverse") {
        return Err(ctx.err(
            f.span(),
            "material.fibre",
            "a fibre direction belongs to transversely isotropic materials; add kind = \"transverse\" or remove it",
        ));
    }
    Ok(())
}

/// The material of `[materials]` named at `name` (key `key`), as a phase's: refused with the
/// known names where there is none.
fn named_material(
    ctx: &Ctx,
    raw: &RawCase,
    name: &Spanned<String>,
    key: &str,
    spans: &mut Spans,
) -> Result<PhaseMaterial, CaseError> {
    let n = name.get_ref();
    let Some(m) = raw.materials.get(n) else {
        let known: Vec<&str> = raw.materials.keys().map(String::as_str).collect();
        let fix = if known.is_empty() {
            "define it in a [materials.NAME] table (youngs, poisson, density)".to_string()
        } else {
            format!("the materials are {}", known.join(", "))
        };
        return Err(ctx.err(
            name.span(),
            key,
            format!("no material named \"{n}\": {fix}"),
        ));
    };
    spans.at(key, m.span());
    let mkey = format!("materials.{n}");
    let m = m.get_ref();
    let mut pm = PhaseMaterial::new(
        n.clone(),
        *m.youngs.get_ref(),
        *m.poisson.get_ref(),
        *m.density.get_ref(),
    );
    pm.toughness = toughness(ctx, &m.critical_stretch, &m.fracture_energy, &mkey)?;
    if let Some(w) = &m.weibull {
        pm.weibull = Some(weibull(ctx, w, &format!("{mkey}.weibull"))?);
    }
    Ok(pm)
}

/// The `[[inclusions]]`: each a material of `[materials]` placed as random balls (the builder
/// places them, and refuses a fraction it cannot reach with the fraction reached).
fn inclusions(
    ctx: &Ctx,
    raw: &RawCase,
    mut b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    use hooke_sim::inclusions::{Grading, InclusionSpec};
    for (i, inc) in raw.inclusions.iter().enumerate() {
        let key = format!("inclusions[{i}]");
        let r = inc.get_ref();
        spans.at(key.clone(), inc.span());
        let material = named_material(ctx, raw, &r.material, &format!("{key}.material"), spans)?;
        for (name, v) in [
            ("fraction", &r.fraction),
            ("d_min", &r.d_min),
            ("d_max", &r.d_max),
        ] {
            spans.at(format!("{key}.{name}"), v.span());
        }
        let exponent = match &r.fuller_exponent {
            None => 0.5,
            Some(e) => {
                spans.at(format!("{key}.grading"), e.span());
                *e.get_ref()
            }
        };
        let grading = match r.grading.as_ref().map(|g| (g.get_ref().as_str(), g)) {
            None | Some(("fuller", _)) => Grading::Fuller { exponent },
            Some(("uniform", _)) => Grading::Uniform,
            Some((other, g)) => {
                return Err(ctx.err(
                    g.span(),
                    format!("{key}.grading"),
                    format!("\"{other}\": give \"fuller\" (Fuller's curve) or \"uniform\""),
                ))
            }
        };
        let gap = match &r.gap {
            None => 0.0,
            Some(g) => {
                spans.at(format!("{key}.gap"), g.span());
                *g.get_ref()
            }
        };
        let seed = seed(ctx, &r.seed, &key)?;
        let spec = InclusionSpec {
            grading,
            d_min: *r.d_min.get_ref(),
            d_max: *r.d_max.get_ref(),
            fraction: *r.fraction.get_ref(),
            gap,
            seed,
        };
        b = b.inclusions(spec, material);
    }
    Ok(b)
}

/// The `[[phases]]`: each names a material of `[materials]` and a shape. An unknown name is
/// refused with the known ones listed; the builder refuses a shape that holds no node.
fn phases(
    ctx: &Ctx,
    raw: &RawCase,
    dim: usize,
    mut b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    for (p, phase) in raw.phases.iter().enumerate() {
        let key = format!("phases[{p}]");
        let ph = phase.get_ref();
        let pm = named_material(ctx, raw, &ph.material, &format!("{key}.material"), spans)?;
        let shape = shape(ctx, &ph.shape, &format!("{key}.shape"), dim)?;
        spans.at(key.clone(), phase.span());
        b = b.phase_of(shape, pm);
    }
    if raw.phases.is_empty() && raw.inclusions.is_empty() {
        if let Some((name, m)) = raw.materials.iter().next() {
            return Err(ctx.err(
                m.span(),
                format!("materials.{name}"),
                "no [[phases]] assigns this material: add a phase (material and shape) or remove it",
            ));
        }
    }
    Ok(b)
}

/// A material's or an interface's own strength: `critical_stretch` or `fracture_energy` (not
/// both) under `key`.
fn toughness(
    ctx: &Ctx,
    stretch: &Option<Spanned<Real>>,
    energy: &Option<Spanned<Real>>,
    key: &str,
) -> Result<Option<Toughness>, CaseError> {
    Ok(match (stretch, energy) {
        (None, None) => None,
        (Some(s), None) => Some(Toughness::Stretch(ctx.positive(
            s,
            &format!("{key}.critical_stretch"),
            "(dimensionless)",
        )?)),
        (None, Some(g)) => Some(Toughness::Energy(ctx.positive(
            g,
            &format!("{key}.fracture_energy"),
            "J/m^2",
        )?)),
        (Some(_), Some(g)) => {
            return Err(ctx.err(
                g.span(),
                format!("{key}.fracture_energy"),
                "give fracture_energy or critical_stretch, not both",
            ))
        }
    })
}

/// A seed under `key` (`KEY.seed`): 0 or more, default 0.
fn seed(ctx: &Ctx, s: &Option<Spanned<i64>>, key: &str) -> Result<u64, CaseError> {
    match s {
        None => Ok(0),
        Some(s) if *s.get_ref() >= 0 => Ok(*s.get_ref() as u64),
        Some(s) => Err(ctx.err(
            s.span(),
            format!("{key}.seed"),
            format!("{}: give a seed of 0 or more", s.get_ref()),
        )),
    }
}

/// `weibull = { modulus, seed }` under `key`: the modulus from 1 to 100, a seed of 0 or more
/// (default 0).
fn weibull(ctx: &Ctx, w: &Spanned<RawWeibull>, key: &str) -> Result<Weibull, CaseError> {
    let r = w.get_ref();
    let seed = seed(ctx, &r.seed, key)?;
    Weibull::new(*r.modulus.get_ref(), seed)
        .map_err(|e| ctx.err(r.modulus.span(), format!("{key}.modulus"), e.to_string()))
}

/// The `[[interfaces]]`: two material names each (checked against the materials by the
/// builder, which names the known ones), an own strength and a stiffness factor.
fn interfaces(
    ctx: &Ctx,
    raw: &RawCase,
    mut b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    for (i, f) in raw.interfaces.iter().enumerate() {
        let key = format!("interfaces[{i}]");
        let r = f.get_ref();
        spans.at(key.clone(), f.span());
        spans.at(format!("{key}.between"), r.between.span());
        let names = r.between.get_ref();
        let [x, y] = names.as_slice() else {
            return Err(ctx.err(
                r.between.span(),
                format!("{key}.between"),
                format!(
                    "{} names: give two materials, e.g. between = [\"mortar\", \"aggregate\"]",
                    names.len()
                ),
            ));
        };
        let stiffness = match &r.stiffness_factor {
            None => 1.0,
            Some(s) => {
                spans.at(format!("{key}.stiffness_factor"), s.span());
                ctx.positive(s, &format!("{key}.stiffness_factor"), "(dimensionless)")?
            }
        };
        b = b.interface(Interface {
            between: [x.clone(), y.clone()],
            toughness: toughness(ctx, &r.critical_stretch, &r.fracture_energy, &key)?,
            stiffness,
        });
    }
    Ok(b)
}

/// `[material]`'s elastic part: `youngs` and `poisson` (the default, `kind = "isotropic"`);
/// `kind = "transverse"` with `youngs_plane`, `youngs_fibre`, `poisson_plane`, `poisson_fibre`,
/// `shear_fibre` and `fibre`; or `kind = "orthotropic"` with `youngs_x|y|z`,
/// `poisson_xy|xz|yz` and `shear_yz|xz|xy`.
fn elastic(
    ctx: &Ctx,
    m: &RawMaterial,
    b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    let isotropic = [("youngs", &m.youngs), ("poisson", &m.poisson)];
    let transverse = [
        ("youngs_plane", &m.youngs_plane),
        ("youngs_fibre", &m.youngs_fibre),
        ("poisson_plane", &m.poisson_plane),
        ("poisson_fibre", &m.poisson_fibre),
        ("shear_fibre", &m.shear_fibre),
    ];
    let orthotropic = [
        ("youngs_x", &m.youngs_x),
        ("youngs_y", &m.youngs_y),
        ("youngs_z", &m.youngs_z),
        ("poisson_xy", &m.poisson_xy),
        ("poisson_xz", &m.poisson_xz),
        ("poisson_yz", &m.poisson_yz),
        ("shear_yz", &m.shear_yz),
        ("shear_xz", &m.shear_xz),
        ("shear_xy", &m.shear_xy),
    ];
    let kind = material_kind(ctx, m, spans)?;
    refuse_foreign_keys(
        ctx,
        m,
        kind,
        [&isotropic[..], &transverse[..], &orthotropic[..]],
    )?;
    let at = m.kind.as_ref().map_or(m.density.span(), |k| k.span());
    let mut values = |keys: &[(&str, &Option<Spanned<Real>>)]| -> Result<Vec<Real>, CaseError> {
        let names: Vec<&str> = keys.iter().map(|(k, _)| *k).collect();
        keys.iter()
            .map(|&(key, v)| {
                let v = v.as_ref().ok_or_else(|| {
                    ctx.err(
                        at.clone(),
                        format!("material.{key}"),
                        format!(
                            "missing: {} {kind} material needs {}",
                            if kind == "transverse" { "a" } else { "an" },
                            names.join(", ")
                        ),
                    )
                })?;
                spans.at(format!("material.{key}"), v.span());
                Ok(*v.get_ref())
            })
            .collect()
    };
    let density = *m.density.get_ref();
    match kind {
        "isotropic" => {
            let c = values(&isotropic)?;
            Ok(b.material(c[0], c[1], density))
        }
        "orthotropic" => {
            let c = values(&orthotropic)?;
            let axes = material_axes(ctx, m, spans)?;
            Ok(b.orthotropic(hooke_core::Orthotropic {
                youngs: [c[0], c[1], c[2]],
                poisson: [c[3], c[4], c[5]],
                shear: [c[6], c[7], c[8]],
                density,
                axes,
            }))
        }
        _ => {
            let c = values(&transverse)?;
            let fibre = material_fibre(ctx, m, at, spans)?;
            Ok(b.transverse(hooke_core::Transverse {
                youngs_plane: c[0],
                youngs_fibre: c[1],
                poisson_plane: c[2],
                poisson_fibre: c[3],
                shear_fibre: c[4],
                density,
                fibre,
            }))
        }
    }
}

/// `material.softening`: the softening curve's shape (linear by default).
fn softening_shape(
    ctx: &Ctx,
    m: &RawMaterial,
    spans: &mut Spans,
) -> Result<SofteningShape, CaseError> {
    Ok(match &m.softening {
        None => SofteningShape::Linear,
        Some(v) => {
            spans.at("material.softening", v.span());
            match v.get_ref().as_str() {
                "linear" => SofteningShape::Linear,
                "bilinear" => SofteningShape::Bilinear,
                other => {
                    return Err(ctx.err(
                        v.span(),
                        "material.softening",
                        format!("unknown softening \"{other}\"; use \"linear\" or \"bilinear\""),
                    ))
                }
            }
        }
    })
}

/// The strength that goes with a softening material's G_f (`g`): its tensile strength or its
/// characteristic length, one of them.
fn softening_strength(
    ctx: &Ctx,
    m: &RawMaterial,
    g: &Spanned<Real>,
    spans: &mut Spans,
) -> Result<Strength, CaseError> {
    Ok(match (&m.tensile_strength, &m.characteristic_length) {
        (Some(f), None) => {
            spans.at("material.tensile_strength", f.span());
            Strength::Tensile(ctx.positive(f, "material.tensile_strength", "Pa")?)
        }
        (None, Some(l)) => {
            spans.at("material.characteristic_length", l.span());
            Strength::CharacteristicLength(ctx.positive(
                l,
                "material.characteristic_length",
                "m",
            )?)
        }
        (Some(f), Some(_)) => {
            return Err(ctx.err(
                f.span(),
                "material.tensile_strength",
                "give tensile_strength or characteristic_length, not both",
            ))
        }
        (None, None) => {
            return Err(ctx.err(
                g.span(),
                "material.fracture_energy",
                "softening springs need a strength too: add tensile_strength (Pa) or \
                 characteristic_length (m, E G_f / f_t^2)",
            ))
        }
    })
}

/// `material.criterion = "softening"`: the curve's shape, then G_f with the tensile strength or
/// the characteristic length, or the peak and final stretches.
fn softening_rule(
    ctx: &Ctx,
    m: &RawMaterial,
    b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    let shape = softening_shape(ctx, m, spans)?;
    if let Some(c) = &m.critical_stretch {
        return Err(ctx.err(
            c.span(),
            "material.critical_stretch",
            "softening springs take peak_stretch and final_stretch (or fracture_energy with \
             tensile_strength); remove critical_stretch",
        ));
    }
    if let Some(c) = &m.criterion {
        spans.at("material.criterion", c.span());
    }
    match (&m.fracture_energy, &m.peak_stretch, &m.final_stretch) {
        (Some(g), None, None) => {
            spans.at("material.fracture_energy", g.span());
            let g_f = ctx.positive(g, "material.fracture_energy", "J/m^2")?;
            let strength = softening_strength(ctx, m, g, spans)?;
            Ok(b.breaking(BreakRule::Softening {
                fracture_energy: g_f,
                strength,
                shape,
            }))
        }
        (None, Some(p), Some(f)) => {
            spans.at("material.peak_stretch", p.span());
            spans.at("material.final_stretch", f.span());
            let peak = ctx.positive(p, "material.peak_stretch", "(dimensionless)")?;
            let last = ctx.positive(f, "material.final_stretch", "(dimensionless)")?;
            if last <= peak {
                return Err(ctx.err(
                    f.span(),
                    "material.final_stretch",
                    format!(
                        "{last} is not above peak_stretch = {peak}: a softening spring cannot \
                         snap back; give a final stretch above the peak"
                    ),
                ));
            }
            if let Some(t) = m.tensile_strength.as_ref().or(m.characteristic_length.as_ref()) {
                return Err(ctx.err(
                    t.span(),
                    "material.tensile_strength",
                    "peak_stretch and final_stretch already fix the curve; remove this key",
                ));
            }
            Ok(b.breaking(BreakRule::SofteningStretch { peak, last, shape }))
        }
        (Some(g), _, _) => Err(ctx.err(
            g.span(),
            "material.fracture_energy",
            "give fracture_energy (with tensile_strength) or peak_stretch and final_stretch, not both",
        )),
        (None, Some(p), None) => Err(ctx.err(
            p.span(),
            "material.peak_stretch",
            "add final_stretch (the stretch at which a spring is broken)",
        )),
        (None, None, Some(f)) => Err(ctx.err(
            f.span(),
            "material.final_stretch",
            "add peak_stretch (the stretch at which a spring starts to soften)",
        )),
        (None, None, None) => Err(ctx.err(
            m.criterion.as_ref().map(|c| c.span()).unwrap_or_else(|| m.density.span()),
            "material.criterion",
            "softening springs need fracture_energy with tensile_strength (or \
             characteristic_length), or peak_stretch with final_stretch",
        )),
    }
}

/// `[[precrack]]`: segments cut 2D bodies, planar polygons 3D ones.
fn precracks(
    ctx: &Ctx,
    raw: &RawCase,
    dim: usize,
    mut b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    for (n, c) in raw.precrack.iter().enumerate() {
        let key = format!("precrack[{n}]");
        let crack = match (&c.segment, &c.polygon) {
            (Some(s), None) => {
                let p = s.get_ref();
                if dim != 2 || p.len() != 2 || p.iter().any(|q| q.len() != 2) {
                    return Err(ctx.err(s.span(), &key, "a segment is two 2D points [[x, y], [x, y]] and cuts 2D (hex) bodies; 3D bodies take a polygon"));
                }
                spans.at(&key, s.span());
                Crack::Segment {
                    a: [p[0][0], p[0][1]],
                    b: [p[1][0], p[1][1]],
                }
            }
            (None, Some(s)) => {
                let p = s.get_ref();
                if dim != 3 || p.len() < 3 || p.iter().any(|q| q.len() != 3) {
                    return Err(ctx.err(s.span(), &key, "a polygon is three or more 3D points [[x, y, z], ...] and cuts 3D (cubic) bodies; 2D bodies take a segment"));
                }
                spans.at(&key, s.span());
                Crack::Polygon {
                    vertices: p.iter().map(|q| [q[0], q[1], q[2]]).collect(),
                }
            }
            _ => {
                return Err(ctx.err(
                    0..0,
                    &key,
                    "give exactly one of segment = [[x, y], [x, y]] or polygon = [[x, y, z], ...]",
                ))
            }
        };
        b = b.precrack(crack);
    }
    Ok(b)
}

/// A region of a `[[boundary]]` or an `[[initial]]` condition.
fn region(ctx: &Ctx, r: &Spanned<RawRegion>, key: &str, dim: usize) -> Result<Region, CaseError> {
    let reg = r.get_ref();
    Ok(match (&reg.bbox, &reg.plane, &reg.face) {
        (None, None, Some(f)) => {
            let s = f.get_ref().as_str();
            Region::Face(Face::parse(s, dim).ok_or_else(|| {
                ctx.err(
                    f.span(),
                    format!("{key}.face"),
                    format!(
                        "unknown face \"{s}\"; use \"x-\", \"x+\", \"y-\", \"y+\"{}",
                        if dim == 3 {
                            ", \"z-\" or \"z+\""
                        } else {
                            " (2D)"
                        }
                    ),
                )
            })?)
        }
        (Some(b), None, None) => Region::Box {
            lo: ctx.point(&b.min, &format!("{key}.box.min"), dim)?,
            hi: ctx.point(&b.max, &format!("{key}.box.max"), dim)?,
        },
        (None, Some(p), None) => Region::Plane {
            axis: axis_index(ctx, &p.axis, &format!("{key}.plane.axis"), dim)?,
            at: *p.at.get_ref(),
            tolerance: match &p.tolerance {
                Some(t) => Some(ctx.positive(t, &format!("{key}.plane.tolerance"), "m")?),
                None => None,
            },
        },
        _ => return Err(ctx.err(r.span(), key, "give exactly one of box = { min = [...], max = [...] }, plane = { axis = \"x\", at = 0.0 } or face = \"x+\"")),
    })
}

/// A value or table in time: constant, ramped (smoothly or not) from 0, or tabulated.
fn time_function(ctx: &Ctx, mo: &RawMotion, key: &str) -> Result<TimeFunction, CaseError> {
    match (&mo.value, &mo.table) {
        (Some(v), None) => Ok(ramped(ctx, *v.get_ref(), &mo.ramp, mo.smooth, key)?),
        (None, Some(t)) => {
            let pts: Option<Vec<(Real, Real)>> = t
                .get_ref()
                .iter()
                .map(|p| (p.len() == 2).then(|| (p[0], p[1])))
                .collect();
            let f = TimeFunction::Table(pts.ok_or_else(|| {
                ctx.err(
                    t.span(),
                    format!("{key}.table"),
                    "each table entry is [time in s, value]",
                )
            })?);
            f.validate()
                .map_err(|e| ctx.err(t.span(), format!("{key}.table"), e.to_string()))?;
            Ok(f)
        }
        _ => Err(ctx.err(
            mo.axis.span(),
            key,
            "give value = ... (with an optional ramp = seconds) or table = [[t, value], ...]",
        )),
    }
}

/// `to`, reached from 0 over `ramp` seconds (smoothly or linearly), or at once.
fn ramped(
    ctx: &Ctx,
    to: Real,
    ramp: &Option<Spanned<Real>>,
    smooth: bool,
    key: &str,
) -> Result<TimeFunction, CaseError> {
    Ok(match ramp {
        None => TimeFunction::Constant(to),
        Some(r) => {
            let t1 = ctx.positive(r, &format!("{key}.ramp"), "s")?;
            if smooth {
                TimeFunction::SmoothRamp {
                    t0: 0.0,
                    t1,
                    from: 0.0,
                    to,
                }
            } else {
                TimeFunction::Ramp {
                    t0: 0.0,
                    t1,
                    from: 0.0,
                    to,
                }
            }
        }
    })
}

/// `[[boundary]]` and `[[initial]]`: conditions on regions.
fn boundaries(
    ctx: &Ctx,
    raw: &RawCase,
    dim: usize,
    mut builder: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    for (n, b) in raw.boundary.iter().enumerate() {
        let key = format!("boundary[{n}]");
        let mut bc = Bc::on(region(ctx, &b.region, &format!("{key}.region"), dim)?);
        spans.at(&key, b.region.span());
        spans.at(format!("{key}.region"), b.region.span());
        for ax in &b.fixed {
            bc = bc.fixed(axis_index(ctx, ax, &format!("{key}.fixed"), dim)?);
        }
        for (list, name) in [(&b.velocity, "velocity"), (&b.displacement, "displacement")] {
            for (j, mo) in list.iter().enumerate() {
                let k2 = format!("{key}.{name}[{j}]");
                let axis = axis_index(ctx, &mo.axis, &format!("{k2}.axis"), dim)?;
                let f = time_function(ctx, mo, &k2)?;
                bc = if name == "velocity" {
                    bc.velocity(axis, f)
                } else {
                    bc.displacement(axis, f)
                };
            }
        }
        for (j, tr) in b.traction.iter().enumerate() {
            let k2 = format!("{key}.traction[{j}]");
            let t = ctx.point(&tr.value, &format!("{k2}.value"), dim)?;
            let normal = axis_index(ctx, &tr.normal, &format!("{k2}.normal"), dim)?;
            let scale = ramped(ctx, 1.0, &tr.ramp, tr.smooth, &k2)?;
            bc = bc.traction([t.x, t.y, t.z], normal, scale);
        }
        if b.no_fail {
            bc = bc.no_fail();
        }
        builder = builder.boundary(bc);
    }
    for (n, init) in raw.initial.iter().enumerate() {
        let key = format!("initial[{n}]");
        let v = ctx.point(&init.velocity, &format!("{key}.velocity"), dim)?;
        let r = match &init.region {
            Some(r) => {
                spans.at(format!("{key}.region"), r.span());
                region(ctx, r, &format!("{key}.region"), dim)?
            }
            None => Region::All,
        };
        builder = builder.initial_velocity(r, [v.x, v.y, v.z]);
    }
    Ok(builder)
}

/// `solver.dt` (a fixed step) or `solver.safety` (a fraction of the stable step), one of them.
fn time_step(ctx: &Ctx, s: &RawSolver) -> Result<TimeStep, CaseError> {
    Ok(match (&s.dt, &s.safety) {
        (Some(dt), None) => TimeStep::Fixed {
            dt: ctx.positive(dt, "solver.dt", "s")?,
            force: false,
        },
        (None, Some(sf)) => {
            let v = *sf.get_ref();
            if !(v > 0.0 && v <= 1.0) {
                return Err(ctx.err(
                    sf.span(),
                    "solver.safety",
                    format!("{v}: give 0 < safety <= 1 (default 0.8)"),
                ));
            }
            TimeStep::Auto { safety: v }
        }
        (None, None) => TimeStep::default(),
        (Some(dt), Some(_)) => {
            return Err(ctx.err(dt.span(), "solver.dt", "give dt or safety, not both"))
        }
    })
}

/// `output.format`: which of VTK and HDF5 a run writes (VTK alone by default).
fn formats(ctx: &Ctx, o: &RawOutput, spans: &mut Spans) -> Result<(bool, bool), CaseError> {
    let (mut vtk, mut hdf5) = (true, false);
    if let Some(f) = &o.format {
        spans.at("output.format", f.span());
        (vtk, hdf5) = (false, false);
        for name in f.get_ref() {
            match name.as_str() {
                "vtk" => vtk = true,
                "hdf5" => hdf5 = true,
                other => {
                    return Err(ctx.err(
                        f.span(),
                        "output.format",
                        format!("unknown format \"{other}\"; use \"vtk\" and/or \"hdf5\""),
                    ))
                }
            }
        }
        if !vtk && !hdf5 {
            return Err(ctx.err(
                f.span(),
                "output.format",
                "give at least one format: [\"vtk\"], [\"hdf5\"] or both",
            ));
        }
    }
    Ok((vtk, hdf5))
}

/// `[solver]` and `[output]`: time stepping, damping, quasi-static load steps, what to write.
fn schedule(ctx: &Ctx, raw: &RawCase, b: Builder, spans: &mut Spans) -> Result<Builder, CaseError> {
    let s = &raw.solver;
    let end_time = ctx.positive(&s.end_time, "solver.end_time", "s")?;
    let time_step = time_step(ctx, s)?;
    let damping = match &s.damping {
        Some(d) if !(d.get_ref().is_finite() && *d.get_ref() >= 0.0) => {
            return Err(ctx.err(
                d.span(),
                "solver.damping",
                "give zero or a positive coefficient in 1/s",
            ))
        }
        Some(d) => *d.get_ref(),
        None => 0.0,
    };
    let mut b = b.end_time(end_time).time_step(time_step).damping(damping);
    let o = &raw.output;
    if let Some(e) = &o.every {
        b = b.output_every(ctx.positive(e, "output.every", "s")?);
    }
    if let Some(e) = &o.checkpoint_every {
        b = b.checkpoint_every(ctx.positive(e, "output.checkpoint_every", "s")?);
    }
    if let Some(e) = &o.reactions_every {
        b = b.reactions_every(ctx.positive(e, "output.reactions_every", "s")?);
    }
    match s.kind.as_ref().map(|k| (k.get_ref().as_str(), k.span())) {
        None | Some(("explicit", _)) => {
            if let Some(st) = &s.steps {
                return Err(ctx.err(
                    st.span(),
                    "solver.steps",
                    "load steps are for type = \"quasi-static\"; explicit runs take end_time",
                ));
            }
        }
        Some(("quasi-static", _)) => {
            let n = match &s.steps {
                Some(st) if *st.get_ref() < 1 || *st.get_ref() > 1_000_000 => {
                    return Err(ctx.err(
                        st.span(),
                        "solver.steps",
                        "give 1 to 1 000 000 load steps",
                    ))
                }
                Some(st) => *st.get_ref() as usize,
                None => 20,
            };
            b = b.quasi_static(n);
        }
        Some((other, span)) => {
            return Err(ctx.err(
                span,
                "solver.type",
                format!("unknown solver \"{other}\"; use \"explicit\" or \"quasi-static\""),
            ))
        }
    }
    let (vtk, hdf5) = formats(ctx, o, spans)?;
    let mut fields = hooke_io::FieldSet::ALL;
    if let Some(f) = &o.fields {
        spans.at("output.fields", f.span());
        fields = hooke_io::FieldSet::from_names(f.get_ref())
            .map_err(|why| ctx.err(f.span(), "output.fields", why))?;
    }
    Ok(b.formats(vtk, hdf5).springs(o.springs).fields(fields))
}

/// TOML to the raw schema: a syntax error, an unknown or a missing key names the key and the line.
fn parse(ctx: &Ctx) -> Result<RawCase, CaseError> {
    let (text, file) = (ctx.text, ctx.file);
    toml::from_str(text).map_err(|e| {
        let mut span = e.span().unwrap_or(0..0);
        let mut key = String::from("(syntax)");
        // toml reports an unknown key at the start of its table: point at the key itself.
        if let Some(name) = e
            .message()
            .split("unknown field `")
            .nth(1)
            .and_then(|r| r.split('`').next())
        {
            key = name.to_string();
            let mut at = span.start;
            for line in text[span.start.min(text.len())..].split_inclusive('\n') {
                let trimmed = line.trim_start();
                if trimmed.starts_with(name)
                    && trimmed[name.len()..]
                        .trim_start()
                        .starts_with(['=', '.', ' '])
                {
                    span = (at + line.len() - trimmed.len())..(at + line.len());
                    break;
                }
                at += line.len();
            }
        } else if let Some(name) = e
            .message()
            .split("missing field `")
            .nth(1)
            .and_then(|r| r.split('`').next())
        {
            key = name.to_string();
        }
        if key == "(syntax)" {
            // A value of the wrong type: name the key written on the line the error points at.
            let line_start = text[..span.start.min(text.len())]
                .rfind('\n')
                .map_or(0, |p| p + 1);
            let line = text[line_start..].lines().next().unwrap_or("");
            if let Some((k, _)) = line.split_once('=') {
                let k = k.trim();
                if !k.is_empty()
                    && k.chars()
                        .all(|c| c.is_alphanumeric() || c == '_' || c == '.')
                {
                    key = k.to_string();
                }
            }
        }
        let (line, column) = line_col(text, span.start);
        // toml names the unknown key and lists the expected ones in its message.
        let msg = e.message().trim().replace('\n', " ");
        let fix = if msg.contains("unknown field") {
            " (see docs/case-format.md for the keys)"
        } else if msg.contains("missing field") {
            " (add it; see docs/case-format.md)"
        } else {
            ""
        };
        CaseError {
            file: file.to_path_buf(),
            line,
            column,
            key,
            message: format!("{msg}{fix}"),
        }
    })
}

/// The body's solid: the bounding box and the shapes added and subtracted (the lattice fills
/// the box, then keeps the nodes inside the body), and where its errors point (the box's max,
/// the first shape, or both given, the box's min).
fn solid(
    ctx: &Ctx,
    raw: &RawCase,
    dim: usize,
) -> Result<(Solid, std::ops::Range<usize>), CaseError> {
    let geo = &raw.geometry;
    let mut adds = Vec::new();
    for (k, sh) in geo.add.iter().enumerate() {
        adds.push(shape(ctx, sh, &format!("geometry.add[{k}]"), dim)?);
    }
    let mut subs = Vec::new();
    for (k, sh) in geo.subtract.iter().enumerate() {
        subs.push(shape(ctx, sh, &format!("geometry.subtract[{k}]"), dim)?);
    }
    let bbox = match &geo.bbox {
        Some(g) => Some((
            ctx.point(&g.min, "geometry.box.min", dim)?,
            ctx.point(&g.max, "geometry.box.max", dim)?,
        )),
        None => None,
    };
    // Where geometry errors point: the box's max, the first shape, or (both given) the box's min.
    let geo_span = match (&geo.bbox, geo.add.first()) {
        (Some(g), None) => g.max.span(),
        (None, Some(sh)) => sh.span(),
        (Some(g), Some(_)) => g.min.span(),
        (None, None) => 0..0,
    };
    let geometry = Solid {
        bbox,
        add: adds,
        subtract: subs,
    };

    Ok((geometry, geo_span))
}

/// `lattice.plane`: how a 2D lattice stands for the material (plane stress by default).
fn plane_model(ctx: &Ctx, l: &RawLattice, kind: LatticeKind) -> Result<PlaneModel, CaseError> {
    Ok(match &l.plane {
        None => PlaneModel::Stress,
        Some(p) if kind.dim() == 3 => {
            return Err(ctx.err(
                p.span(),
                "lattice.plane",
                "only 2D lattices take a plane model; remove it",
            ))
        }
        Some(p) => match p.get_ref().as_str() {
            "stress" => PlaneModel::Stress,
            "strain" => PlaneModel::Strain,
            other => {
                return Err(ctx.err(
                    p.span(),
                    "lattice.plane",
                    format!("unknown plane model \"{other}\"; use \"stress\" or \"strain\""),
                ))
            }
        },
    })
}

/// `[lattice]` and `[geometry]`: the kind, spacing (divided by `scale`), plate thickness, plane
/// model, random sampling and the body's shapes.
fn lattice(
    ctx: &Ctx,
    raw: &RawCase,
    scale: Real,
    spans: &mut Spans,
) -> Result<(Builder, LatticeKind, Real), CaseError> {
    // Lattice.
    let l = &raw.lattice;
    let kind = match l.kind.get_ref().as_str() {
        "cubic" => LatticeKind::Cubic,
        "hex" => LatticeKind::Hex,
        "random2d" => LatticeKind::Random2d,
        "random3d" => LatticeKind::Random3d,
        other => {
            return Err(ctx.err(
                l.kind.span(),
                "lattice.kind",
                format!(
                "unknown lattice \"{other}\"; use \"cubic\" (3D Ladd), \"hex\" (2D hexagonal), \"random2d\" or \"random3d\""
            ),
            ))
        }
    };
    let random = random_spec(ctx, l, kind)?;
    let dim = kind.dim();
    let a = ctx.positive(&l.spacing, "lattice.spacing", "m")? / scale;
    let h = match (&l.thickness, kind.dim()) {
        (Some(t), 2) => ctx.positive(t, "lattice.thickness", "m")?,
        (None, 2) => {
            return Err(ctx.err(
                l.kind.span(),
                "lattice.thickness",
                "a 2D lattice is a plate: give its thickness in m",
            ))
        }
        (Some(t), _) => {
            return Err(ctx.err(
                t.span(),
                "lattice.thickness",
                "only 2D (hex) lattices have a thickness; remove it",
            ))
        }
        (None, _) => 1.0,
    };
    let plane = plane_model(ctx, l, kind)?;
    let (geometry, geo_span) = solid(ctx, raw, dim)?;

    spans.at("lattice.spacing", l.spacing.span());
    spans.at(
        "lattice.thickness",
        l.thickness.as_ref().map_or(l.kind.span(), |t| t.span()),
    );
    spans.at("geometry", geo_span);
    let mut b = Builder::new(kind, a)
        .plane(plane)
        .random(random)
        .solid(geometry);
    if dim == 2 {
        b = b.thickness(h);
    }
    if let Some(r) = &l.rotate_to {
        spans.at("lattice.rotate_to", r.span());
        if kind != LatticeKind::Cubic {
            return Err(ctx.err(
                r.span(),
                "lattice.rotate_to",
                "only the cubic lattice is turned (random lattices have no axes); remove it",
            ));
        }
        let &[x, y, z] = r.get_ref().as_slice() else {
            return Err(ctx.err(
                r.span(),
                "lattice.rotate_to",
                "give three numbers, a direction, e.g. rotate_to = [0.866, 0.5, 0] (a fibre's)",
            ));
        };
        b = b.rotate_lattice([x, y, z]);
    }
    if let Some(w) = &l.cell_weights {
        // The builder checks it against the lattice (random, turned, periodic, too thin).
        spans.at("lattice.cell_weights", w.span());
        b = b.cell_weights(*w.get_ref());
    }
    Ok((b, kind, h))
}

/// Rigid bodies and contact settings, for the builder (which checks them against the body
/// and places the bodies); unchanged when the case has neither.
fn contact(
    ctx: &Ctx,
    raw: &RawCase,
    dim: usize,
    h: Real,
    b: Builder,
    spans: &mut Spans,
) -> Result<Builder, CaseError> {
    if raw.rigid.is_empty() && raw.contact.is_none() {
        return Ok(b);
    }
    let mut spec = ContactSpec::default();
    if let Some(c) = &raw.contact {
        spans.at("contact", c.span());
        let c = c.get_ref();
        if let Some(v) = &c.stiffness_factor {
            spans.at("contact.stiffness_factor", v.span());
            spec.stiffness_factor = Some(*v.get_ref());
        }
        if let Some(v) = &c.radius {
            spans.at("contact.radius", v.span());
            spec.radius = Some(*v.get_ref());
        }
        spec.fragments = c.fragments;
        if let Some(v) = &c.fragment_distance {
            spans.at("contact.fragment_distance", v.span());
            spec.fragment_distance = Some(*v.get_ref());
        }
    }
    let mut bodies = Vec::new();
    for (k, r) in raw.rigid.iter().enumerate() {
        spans.at(format!("rigid[{k}]"), r.span());
        spans.at(format!("rigid[{k}].position"), r.get_ref().position.span());
        if let Some(g) = &r.get_ref().start_gap {
            spans.at(format!("rigid[{k}].start_gap"), g.span());
        }
        if raw.contact.is_none() && k == 0 {
            spans.at("contact", r.span());
        }
        bodies.push(RigidSpec {
            body: rigid(ctx, r, k, dim, h)?,
            start_gap: r.get_ref().start_gap.as_ref().map(|g| *g.get_ref()),
        });
    }
    Ok(b.contact(spec, bodies))
}

/// A rigid body's shape (`rigid[k].shape`): exactly one of its kinds, checked for the
/// body's dimension.
fn rigid_geometry(ctx: &Ctx, raw: &RawRigid, key: &str, dim: usize) -> Result<Geometry, CaseError> {
    let sh = raw.shape.get_ref();
    let given = [
        sh.sphere.is_some(),
        sh.circle.is_some(),
        sh.bbox.is_some(),
        sh.cylinder.is_some(),
        sh.capsule.is_some(),
        sh.halfspace.is_some(),
        sh.polygon.is_some(),
        sh.mesh.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if given != 1 {
        return Err(ctx.err(
            raw.shape.span(),
            format!("{key}.shape"),
            "give exactly one of sphere (circle), box, cylinder, capsule, halfspace, polygon (2D) or mesh (3D)",
        ));
    }
    let span = raw.shape.span();
    let skey = format!("{key}.shape");
    let axis_vec = |a: &Spanned<String>, akey: &str| -> Result<usize, CaseError> {
        axis_index(ctx, a, akey, dim)
    };
    let radius = |b: &RawRadius| ctx.positive(&b.radius, &format!("{skey}.radius"), "m");
    Ok(if let Some(b) = sh.sphere.as_ref().or(sh.circle.as_ref()) {
        Geometry::ball(dim, radius(b)?)
    } else if let Some(b) = &sh.bbox {
        let v = ctx.point(&b.size, &format!("{skey}.box.size"), dim)?;
        if (0..dim).any(|c| v[c] <= 0.0) {
            return Err(ctx.err(
                b.size.span(),
                format!("{skey}.box.size"),
                "give the positive edge lengths (m)",
            ));
        }
        Geometry::cuboid(dim, [v.x, v.y, v.z])
    } else if let Some(c) = &sh.cylinder {
        if dim == 2 {
            return Err(ctx.err(span, skey, "a cylinder is 3D; use box or capsule in 2D"));
        }
        let rad = ctx.positive(&c.radius, &format!("{skey}.cylinder.radius"), "m")?;
        let len = ctx.positive(&c.length, &format!("{skey}.cylinder.length"), "m")?;
        Geometry::cylinder(
            rad,
            len,
            axis_vec(&c.axis, &format!("{skey}.cylinder.axis"))?,
        )
    } else if let Some(c) = &sh.capsule {
        let rad = ctx.positive(&c.radius, &format!("{skey}.capsule.radius"), "m")?;
        let len = ctx.positive(&c.length, &format!("{skey}.capsule.length"), "m")?;
        Geometry::capsule(
            dim,
            rad,
            len,
            axis_vec(&c.axis, &format!("{skey}.capsule.axis"))?,
        )
    } else if let Some(hs) = &sh.halfspace {
        Geometry::halfspace(
            dim,
            unit(ctx, &hs.normal, &format!("{skey}.halfspace.normal"), dim)?,
        )
    } else if let Some(p) = &sh.polygon {
        let pts = p.points.get_ref();
        let pkey = format!("{skey}.polygon.points");
        if dim == 3 {
            return Err(ctx.err(
                p.points.span(),
                pkey,
                "a polygon body is 2D; use box, cylinder, capsule or mesh in 3D",
            ));
        }
        if pts.len() < 3
            || pts
                .iter()
                .any(|q| q.len() != 2 || !q.iter().all(|v| v.is_finite()))
        {
            return Err(ctx.err(
                p.points.span(),
                pkey,
                "a convex polygon is three or more points [x, y] (m, relative to the position)",
            ));
        }
        let v: Vec<[Real; 2]> = pts.iter().map(|q| [q[0], q[1]]).collect();
        Geometry::convex_polygon(&v).map_err(|e| ctx.err(p.points.span(), pkey, e))?
    } else {
        let m = sh.mesh.as_ref().expect("one shape is given");
        if dim == 2 {
            return Err(ctx.err(
                m.file.span(),
                format!("{skey}.mesh"),
                "a mesh body is 3D; use a convex polygon in 2D",
            ));
        }
        Geometry::mesh(&load_mesh(ctx, m, &skey)?)
    })
}

/// A rigid body's motion: kinematic at `velocity`, or dynamic with its mass (given, or from
/// its density and `geometry`; `h` a plate's thickness).
fn rigid_motion(
    ctx: &Ctx,
    r: &Spanned<RawRigid>,
    key: &str,
    (geometry, velocity): (&hooke_contact::Geometry, Vector),
    h: Real,
) -> Result<hooke_contact::Motion, CaseError> {
    let raw = r.get_ref();
    let span = raw.shape.span();
    let unbounded = geometry.is_unbounded();
    let kinematic = match raw.motion.as_ref().map(|m| (m.get_ref().as_str(), m.span())) {
        None | Some(("dynamic", _)) => false,
        Some(("kinematic", _)) => true,
        Some((other, sp)) => {
            return Err(ctx.err(sp, format!("{key}.motion"), format!("unknown motion \"{other}\"; use \"dynamic\" (moved by contact) or \"kinematic\" (prescribed velocity)")))
        }
    };
    Ok(if kinematic {
        if let Some(m) = raw.mass.as_ref().or(raw.density.as_ref()) {
            return Err(ctx.err(
                m.span(),
                format!("{key}.mass"),
                "a kinematic body moves as prescribed: remove mass and density",
            ));
        }
        hooke_contact::Motion::Kinematic([
            TimeFunction::Constant(velocity.x),
            TimeFunction::Constant(velocity.y),
            TimeFunction::Constant(velocity.z),
        ])
    } else {
        if unbounded {
            return Err(ctx.err(
                span,
                format!("{key}.motion"),
                "a half-space has no finite mass: make it motion = \"kinematic\"",
            ));
        }
        let mass = match (&raw.mass, &raw.density) {
            (Some(m), None) => ctx.positive(m, &format!("{key}.mass"), "kg")?,
            (None, Some(d)) => {
                geometry.mass(ctx.positive(d, &format!("{key}.density"), "kg/m^3")?, h)
            }
            (Some(m), Some(_)) => {
                return Err(ctx.err(
                    m.span(),
                    format!("{key}.mass"),
                    "give mass or density, not both",
                ))
            }
            (None, None) => {
                return Err(ctx.err(
                    r.span(),
                    format!("{key}.mass"),
                    "a dynamic body needs its mass (kg) or density (kg/m^3)",
                ))
            }
        };
        hooke_contact::Motion::Dynamic { mass }
    })
}

fn rigid(
    ctx: &Ctx,
    r: &Spanned<RawRigid>,
    k: usize,
    dim: usize,
    h: Real,
) -> Result<RigidBody, CaseError> {
    let key = format!("rigid[{k}]");
    let raw = r.get_ref();
    let geometry = rigid_geometry(ctx, raw, &key, dim)?;
    let span = raw.shape.span();
    let position = ctx.point(&raw.position, &format!("{key}.position"), dim)?;
    let velocity = match &raw.velocity {
        Some(v) => ctx.point(v, &format!("{key}.velocity"), dim)?,
        None => Vector::zeros(),
    };
    let motion = rigid_motion(ctx, r, &key, (&geometry, velocity), h)?;
    let friction = match &raw.friction {
        None => 0.0,
        Some(f) => {
            let x = *f.get_ref();
            if !(x.is_finite() && x >= 0.0) {
                return Err(ctx.err(
                    f.span(),
                    format!("{key}.friction"),
                    format!("{x}: give a Coulomb coefficient >= 0"),
                ));
            }
            x
        }
    };
    RigidBody::new(
        raw.name.clone().unwrap_or_else(|| format!("rigid{k}")),
        geometry,
        motion,
        [
            position.x,
            position.y,
            if dim == 3 { position.z } else { 0.0 },
        ],
        [
            velocity.x,
            velocity.y,
            if dim == 3 { velocity.z } else { 0.0 },
        ],
        friction,
    )
    .with_spin_settings(
        raw.rotates.as_ref().map(|r| *r.get_ref()),
        raw.angular_velocity
            .as_ref()
            .map(|w| w.get_ref().as_slice()),
        dim,
    )
    .map_err(|(which, why)| {
        let sp = match which {
            "rotates" => raw.rotates.as_ref().map(|r| r.span()),
            _ => raw.angular_velocity.as_ref().map(|w| w.span()),
        };
        ctx.err(sp.unwrap_or(span.clone()), format!("{key}.{which}"), why)
    })
}

fn unit(ctx: &Ctx, v: &Spanned<Vec<Real>>, key: &str, dim: usize) -> Result<[Real; 3], CaseError> {
    let p = ctx.point(v, key, dim)?;
    let n = p.norm();
    if !(n > 0.0) {
        return Err(ctx.err(v.span(), key, "give a non-zero normal vector"));
    }
    Ok([p.x / n, p.y / n, p.z / n])
}
