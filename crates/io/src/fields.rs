//! Derived per-node fields, computed only for output (never on the hot path).

use hooke_core::law;
use hooke_core::{Body, Real, State};

/// Fields derived from a state.
#[derive(Clone, Debug)]
pub struct Derived {
    /// Pool ratio `p_n = Pi_n / S_n`: under uniform strain it equals `tr(eps)/d`, a local
    /// dilatation.
    pub pool: Vec<Real>,
    /// Strain energy density (J/m^3): half of each intact spring's direct energy plus the node's
    /// dispersive energy, over the node's volume. Summed times the volume it gives U exactly.
    pub energy_density: Vec<Real>,
    /// Virial stress `1/(2V_n) sum_t T_t l_t e_t e_t` (Pa), row-major 3x3, V_n the node's volume.
    pub stress: Vec<[Real; 9]>,
}

/// Compute the derived fields of `state` ([`law::frame_fields_of`]).
pub fn derived(body: &Body, state: &State) -> Derived {
    law::frame_fields_of(body, state).into()
}

impl From<law::FrameFields> for Derived {
    fn from(f: law::FrameFields) -> Self {
        Derived {
            pool: f.pool,
            energy_density: f.energy_density,
            stress: f.stress,
        }
    }
}

/// Which point fields a frame writes (`output.fields` of a case): any of [`FieldSet::NAMES`].
/// `node_id` is always written, so that frames of runs on different process counts, or with
/// different fields, can be matched node for node. Fewer fields make smaller frames that cost
/// the run less: on the Kalthoff-Winkler plate the 9-component stress is a third of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FieldSet(u16);

impl FieldSet {
    /// Every selectable field, in the order frames carry them.
    pub const NAMES: [&'static str; 9] = [
        "displacement",
        "velocity",
        "damage",
        "pool_ratio",
        "strain_energy_density",
        "stress",
        "node_volume",
        "region",
        "material",
    ];

    /// Every field (the default).
    pub const ALL: FieldSet = FieldSet((1 << Self::NAMES.len()) - 1);

    /// No selectable field (`node_id` alone).
    pub const NONE: FieldSet = FieldSet(0);

    /// The fields named in `names` (each once); an unknown or repeated name is refused with the
    /// list of names to choose from.
    pub fn from_names<S: AsRef<str>>(names: &[S]) -> Result<Self, String> {
        let mut set = Self::NONE;
        for name in names {
            let name = name.as_ref();
            let Some(k) = Self::NAMES.iter().position(|n| *n == name) else {
                let hint = if name == "node_id" {
                    " (node_id is always written)"
                } else {
                    ""
                };
                return Err(format!(
                    "unknown field \"{name}\"{hint}; choose from {}",
                    Self::NAMES.map(|n| format!("\"{n}\"")).join(", ")
                ));
            };
            if set.0 & (1 << k) != 0 {
                return Err(format!("\"{name}\" is listed twice"));
            }
            set.0 |= 1 << k;
        }
        Ok(set)
    }

    /// Whether the field `name` is in the set (`node_id` always is).
    pub fn has(self, name: &str) -> bool {
        name == "node_id"
            || Self::NAMES
                .iter()
                .position(|n| *n == name)
                .is_some_and(|k| self.0 & (1 << k) != 0)
    }

    /// The fields in both sets.
    pub fn and(self, other: FieldSet) -> FieldSet {
        FieldSet(self.0 & other.0)
    }

    /// The set without the field `name`.
    pub fn without(self, name: &str) -> FieldSet {
        match Self::NAMES.iter().position(|n| *n == name) {
            Some(k) => FieldSet(self.0 & !(1 << k)),
            None => self,
        }
    }

    /// The fields in either set.
    pub fn or(self, other: FieldSet) -> FieldSet {
        FieldSet(self.0 | other.0)
    }

    /// The names of the fields in the set, in [`FieldSet::NAMES`] order.
    pub fn names(self) -> impl Iterator<Item = &'static str> {
        Self::NAMES
            .into_iter()
            .enumerate()
            .filter(move |(k, _)| self.0 & (1 << k) != 0)
            .map(|(_, n)| n)
    }

    /// Whether any field derived from the springs (pool ratio, energy density, stress) is in
    /// the set: frames without them need no derived fields.
    pub fn derived(self) -> bool {
        ["pool_ratio", "strain_energy_density", "stress"]
            .iter()
            .any(|n| self.has(n))
    }
}

impl Default for FieldSet {
    fn default() -> Self {
        Self::ALL
    }
}

#[cfg(test)]
mod tests {
    use super::FieldSet;

    #[test]
    fn field_sets_parse_names_and_refuse_unknown_or_repeated_ones() {
        let s = FieldSet::from_names(&["stress", "displacement"]).unwrap();
        assert!(s.has("stress") && s.has("displacement") && s.has("node_id"));
        assert!(!s.has("velocity") && !s.has("damage") && !s.has("bogus"));
        assert_eq!(s.names().collect::<Vec<_>>(), ["displacement", "stress"]);
        assert!(s.derived());
        assert!(!FieldSet::from_names(&["damage"]).unwrap().derived());
        assert_eq!(FieldSet::from_names::<&str>(&[]).unwrap(), FieldSet::NONE);
        assert_eq!(
            FieldSet::from_names(&FieldSet::NAMES).unwrap(),
            FieldSet::ALL
        );
        assert_eq!(FieldSet::default(), FieldSet::ALL);
        let e = FieldSet::from_names(&["strain"]).unwrap_err();
        assert!(e.contains("\"strain\"") && e.contains("\"stress\""), "{e}");
        let e = FieldSet::from_names(&["node_id"]).unwrap_err();
        assert!(e.contains("always written"), "{e}");
        let e = FieldSet::from_names(&["stress", "stress"]).unwrap_err();
        assert!(e.contains("twice"), "{e}");
        assert_eq!(
            s.and(FieldSet::from_names(&["stress"]).unwrap())
                .names()
                .count(),
            1
        );
        assert_eq!(
            s.without("stress").names().collect::<Vec<_>>(),
            ["displacement"]
        );
        assert_eq!(s.without("stress").or(s), s);
    }
}
