//! Measured fabrics, dry and wet (`[cloth] material = "NAME"`): every value's source is in
//! `docs/materials.md`.

use crate::math::Real;

/// One measured value, dry and soaked; the cloth's wetness moves it linearly between them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DryWet {
    /// The dry fabric's value.
    pub dry: Real,
    /// The soaked fabric's value (wetness 1).
    pub wet: Real,
}

impl DryWet {
    /// The value at wetness `w` (0 dry to 1 soaked): `dry + (wet - dry) w`.
    pub fn at(&self, w: Real) -> Real {
        self.dry + (self.wet - self.dry) * w
    }
}

/// A fabric of the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fabric {
    /// The name a scene gives (`material = "cotton"`).
    pub name: &'static str,
    /// What the fabric is (weave, fibre, weight), for the docs and error messages.
    pub description: &'static str,
    /// Dry areal density, kg/m^2.
    pub density: Real,
    /// Water a soaked fabric holds, kg/m^2.
    pub water_mass: Real,
    /// Tensile stiffness along the warp, N/m.
    pub warp: DryWet,
    /// Tensile stiffness along the weft, N/m.
    pub weft: DryWet,
    /// In-plane shear stiffness, N/m.
    pub shear: DryWet,
    /// Poisson's ratio (weft contraction per unit warp strain), below 0.5.
    pub poisson: Real,
    /// Bending rigidity B, N m.
    pub bending: DryWet,
    /// B along the warp / B.
    pub bending_warp: Real,
    /// B along the weft / B.
    pub bending_weft: Real,
    /// Dry friction as a share of the wet fabric's friction.
    pub dry_friction_factor: Real,
}

const fn dw(dry: Real, wet: Real) -> DryWet {
    DryWet { dry, wet }
}

/// Dry friction over wet friction for every fabric: wet fabric on skin rubs with more than
/// twice the friction of dry fabric (Gerhardt et al. 2008), so 1 / 2.2.
const DRY_FRICTION: Real = 0.45;

/// The table, in the order the docs list it.
pub const FABRICS: &[Fabric] = &[
    Fabric {
        name: "satin",
        description: "polyester satin (filament satin weave), about 120 g/m^2; estimated from the \
                      measured polyester plain weave, no satin measurement found",
        density: 0.120,
        water_mass: 0.102,
        warp: dw(3880.0, 3880.0),
        weft: dw(3880.0, 3880.0),
        shear: dw(9.0, 9.0),
        poisson: 0.381,
        bending: dw(4.3e-6, 4.3e-6),
        bending_warp: 1.0,
        bending_weft: 1.0,
        dry_friction_factor: DRY_FRICTION,
    },
    Fabric {
        name: "cotton",
        description: "plain-weave cotton shirting, 150 g/m^2",
        density: 0.150,
        water_mass: 0.150,
        warp: dw(1120.0, 900.0),
        weft: dw(1120.0, 900.0),
        shear: dw(42.0, 50.0),
        poisson: 0.243,
        bending: dw(4.5e-6, 3.2e-6),
        bending_warp: 1.0,
        bending_weft: 1.0,
        dry_friction_factor: DRY_FRICTION,
    },
    Fabric {
        name: "linen",
        description: "plain-weave linen (flax) apparel fabric, about 190 g/m^2",
        density: 0.190,
        water_mass: 0.190,
        warp: dw(2120.0, 1700.0),
        weft: dw(2120.0, 1700.0),
        shear: dw(53.0, 64.0),
        poisson: 0.243,
        bending: dw(1.36e-5, 9.5e-6),
        bending_warp: 1.0,
        bending_weft: 1.0,
        dry_friction_factor: DRY_FRICTION,
    },
    Fabric {
        name: "denim",
        description: "11 oz cotton denim (99 % cotton, 1 % elastane twill), 324 g/m^2",
        density: 0.324,
        water_mass: 0.324,
        warp: dw(437.0, 350.0),
        weft: dw(2065.0, 1650.0),
        shear: dw(53.0, 64.0),
        poisson: 0.243,
        bending: dw(2.01e-5, 1.41e-5),
        bending_warp: 1.20,
        bending_weft: 0.80,
        dry_friction_factor: DRY_FRICTION,
    },
    Fabric {
        name: "silk",
        description: "silk habotai / light crepe de chine (filament plain weave), about 55 g/m^2",
        density: 0.055,
        water_mass: 0.044,
        warp: dw(1780.0, 1420.0),
        weft: dw(1780.0, 1420.0),
        shear: dw(8.3, 7.5),
        poisson: 0.381,
        bending: dw(8.2e-7, 5.8e-7),
        bending_warp: 1.0,
        bending_weft: 1.0,
        dry_friction_factor: DRY_FRICTION,
    },
    Fabric {
        name: "wool",
        description: "plain-weave wool suiting, 235 g/m^2",
        density: 0.235,
        water_mass: 0.235,
        warp: dw(1750.0, 875.0),
        weft: dw(1750.0, 875.0),
        shear: dw(65.0, 46.0),
        poisson: 0.277,
        bending: dw(1.7e-5, 8.5e-6),
        bending_warp: 1.0,
        bending_weft: 1.0,
        dry_friction_factor: DRY_FRICTION,
    },
    Fabric {
        name: "polyester-jersey",
        description: "100 % polyester knit, 113 g/m^2 (warp: the knit's soft axis)",
        density: 0.113,
        water_mass: 0.057,
        warp: dw(118.0, 118.0),
        weft: dw(576.0, 576.0),
        shear: dw(14.0, 14.0),
        poisson: 0.237,
        bending: dw(4.33e-6, 4.33e-6),
        bending_warp: 1.175,
        bending_weft: 0.825,
        dry_friction_factor: DRY_FRICTION,
    },
    Fabric {
        name: "polyester-plain",
        description: "100 % polyester woven tablecloth fabric, 128 g/m^2",
        density: 0.128,
        water_mass: 0.064,
        warp: dw(4110.0, 4110.0),
        weft: dw(4180.0, 4180.0),
        shear: dw(19.0, 19.0),
        poisson: 0.381,
        bending: dw(1.04e-5, 1.04e-5),
        bending_warp: 0.754,
        bending_weft: 1.246,
        dry_friction_factor: DRY_FRICTION,
    },
];

/// The fabric of this name.
pub fn fabric(name: &str) -> Option<&'static Fabric> {
    FABRICS.iter().find(|f| f.name == name)
}

/// The names, in order, for error messages.
pub fn names() -> Vec<&'static str> {
    FABRICS.iter().map(|f| f.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn in_range(what: &str, name: &str, v: Real, lo: Real, hi: Real) {
        assert!(
            v.is_finite() && v >= lo && v <= hi,
            "{name}: {what} = {v} is not in [{lo}, {hi}]"
        );
    }

    fn both(d: &DryWet) -> [Real; 2] {
        [d.dry, d.wet]
    }

    #[test]
    fn values_are_finite_and_physical() {
        for f in FABRICS {
            let n = f.name;
            in_range("density (kg/m^2)", n, f.density, 0.04, 0.45);
            in_range("water_mass (kg/m^2)", n, f.water_mass, 0.0, 0.5);
            for v in both(&f.warp).into_iter().chain(both(&f.weft)) {
                // knits about 1e2, woven fabrics 1e3 to 1e5 N/m
                in_range("tensile stiffness (N/m)", n, v, 1e2, 1e5);
            }
            for v in both(&f.shear) {
                in_range("shear stiffness (N/m)", n, v, 1.0, 100.0);
            }
            for v in both(&f.bending) {
                in_range("bending rigidity (N m)", n, v, 1e-7, 1e-4);
            }
            in_range("bending_warp", n, f.bending_warp, 0.2, 5.0);
            in_range("bending_weft", n, f.bending_weft, 0.2, 5.0);
            let mean = 0.5 * (f.bending_warp + f.bending_weft);
            assert!(
                (mean - 1.0).abs() < 0.05,
                "{n}: B is not the mean of its directions ({mean})"
            );
            in_range("dry_friction_factor", n, f.dry_friction_factor, 0.0, 1.0);
            assert!(
                f.dry_friction_factor > 0.0,
                "{n}: dry cloth must keep some friction"
            );
        }
    }

    #[test]
    fn membranes_are_stable() {
        for f in FABRICS {
            assert!(
                f.poisson.is_finite() && f.poisson >= 0.0 && f.poisson < 0.5,
                "{}: poisson {}",
                f.name,
                f.poisson
            );
            for (warp, weft) in [(f.warp.dry, f.weft.dry), (f.warp.wet, f.weft.wet)] {
                let nu12_nu21 = f.poisson * f.poisson * weft / warp;
                assert!(
                    nu12_nu21 < 1.0,
                    "{}: poisson^2 weft/warp = {nu12_nu21} is not below 1",
                    f.name
                );
            }
        }
    }

    #[test]
    fn names_are_unique_and_lowercase_with_hyphens() {
        let all = names();
        for (i, n) in all.iter().enumerate() {
            assert!(
                !n.is_empty() && !n.starts_with('-') && !n.ends_with('-') && !n.contains("--"),
                "bad name {n:?}"
            );
            assert!(
                n.chars().all(|c| c.is_ascii_lowercase() || c == '-'),
                "bad name {n:?}"
            );
            assert!(!all[i + 1..].contains(n), "{n} is listed twice");
        }
    }

    #[test]
    fn the_documented_fabrics_exist() {
        for n in [
            "satin",
            "cotton",
            "linen",
            "denim",
            "silk",
            "wool",
            "polyester-jersey",
        ] {
            assert_eq!(fabric(n).map(|f| f.name), Some(n));
        }
        assert!(fabric("velvet").is_none());
        assert_eq!(names().len(), FABRICS.len());
    }

    #[test]
    fn wetness_interpolates() {
        let d = DryWet { dry: 2.0, wet: 4.0 };
        assert_eq!(d.at(0.0), 2.0);
        assert_eq!(d.at(1.0), 4.0);
        assert_eq!(d.at(0.5), 3.0);
    }

    #[test]
    fn the_satin_soaked_weighs_the_reference_cloth() {
        // The reference cloth: 20 g on 0.3 m x 0.3 m, water included.
        let satin = fabric("satin").unwrap();
        let soaked = satin.density + satin.water_mass;
        assert!(
            (soaked - 0.02 / 0.09).abs() < 0.001,
            "soaked satin {soaked} kg/m^2"
        );
    }
}
