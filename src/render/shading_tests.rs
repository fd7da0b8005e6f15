//! Vector shading (`integrator::shade_lanes`) against scalar shading
//! (`PathState::advance`) on the three reference scenes and the nested
//! ones. Both draw each
//! path's random numbers in the same order, so the same path gives the same
//! radiance up to rounding (f32 against f64 Fresnel and Snell), but where a
//! number falls within rounding of a Fresnel reflectance or a direction
//! within rounding of the critical angle: then the path takes the other
//! lobe, and its pixel differs by noise. The tests bound the share of
//! pixels that differ, and show that known-wrong kernels (an interface
//! reflecting with half its Fresnel reflectance; next-event estimation
//! weighed against twice the bounce's density; a nested boundary's index
//! pair taken against the ambient medium) are caught by the same bound.
use super::{render, PacketWidth, RenderOptions, RenderSettings, Shading};
use crate::scene::model::BsdfVariant;
use crate::scene::{load_scene, BuildOptions, RenderScene};
use std::path::Path;

fn scene(name: &str) -> RenderScene {
    load_scene(
        Path::new(&format!("scenes/{name}.toml")),
        &BuildOptions::default(),
    )
    .expect("scene")
}

/// The scene rendered at 80×60, 4 spp, with `shading`, in packets of 16.
fn pixels(s: &RenderScene, shading: Shading) -> Vec<glam::Vec3A> {
    pixels_in(s, shading, PacketWidth::Sixteen)
}

fn pixels_in(s: &RenderScene, shading: Shading, packet_width: PacketWidth) -> Vec<glam::Vec3A> {
    let set = RenderSettings::from_scene(s)
        .with_resolution(80, 60)
        .unwrap()
        .with_spp(4);
    let opts = RenderOptions {
        threads: Some(2),
        shading,
        packet_width,
        ..Default::default()
    };
    render(s, &set, &opts).expect("render").pixels
}

/// The share of pixels whose channels differ by more than 10⁻⁴ relative
/// (and 10⁻⁶ absolute): rounding stays far below, a different lobe far above.
fn differing(a: &[glam::Vec3A], b: &[glam::Vec3A]) -> f64 {
    let n = a
        .iter()
        .zip(b)
        .filter(|(p, q)| {
            let tol = (p.abs() + q.abs()) * 1e-4 + 1e-6;
            ((*p - *q).abs() - tol).max_element() > 0.0
        })
        .count();
    n as f64 / a.len() as f64
}

/// At most this share of pixels may differ: the paths that pick another
/// lobe at a Fresnel or critical-angle tie (a few in 10⁴ here).
const LIMIT: f64 = 0.01;

#[test]
fn vector_shading_gives_the_scalar_paths_and_wrong_kernels_do_not() {
    for name in ["three_spheres", "glass_of_water", "cylinder_refraction"] {
        let mut s = scene(name);
        let scalar = pixels(&s, Shading::Scalar);
        let vector = pixels(&s, Shading::Vector);
        let right = differing(&scalar, &vector);
        // Eight lanes side by side (the kernel's chunks, AVX2's width).
        let eight = differing(&scalar, &pixels_in(&s, Shading::Vector, PacketWidth::Eight));
        assert!(eight <= LIMIT, "{name}, packets of 8: {eight}");
        s.bsdf_variant = BsdfVariant::WrongHalfFresnel;
        let half_fresnel = differing(&scalar, &pixels(&s, Shading::Vector));
        // The variant only changes vector shading: scalar shading of the
        // same scene still agrees with itself (the comparison is of kernels).
        assert_eq!(differing(&scalar, &pixels(&s, Shading::Scalar)), 0.0, "{name}");
        s.bsdf_variant = BsdfVariant::WrongMisPdf;
        let mis = differing(&scalar, &pixels(&s, Shading::Vector));
        eprintln!(
            "{name}: pixels differing from scalar shading: vector {right:.4}, \
             half Fresnel reflectance {half_fresnel:.4}, doubled bounce density in MIS {mis:.4}"
        );
        assert!(right <= LIMIT, "{name}: {right}");
        assert!(
            half_fresnel > LIMIT,
            "{name}: half the Fresnel reflectance passes: {half_fresnel}"
        );
        // cylinder_refraction has no next-event estimation (its only surface
        // that could sample a light is black).
        if name != "cylinder_refraction" {
            assert!(mis > LIMIT, "{name}: the wrong MIS passes: {mis}");
        }
    }
}

/// The nested scenes: their boundaries' index pairs come from the paths'
/// interior lists (the nested rule) in vector shading as in scalar shading.
#[test]
fn vector_shading_of_nested_solids_gives_the_scalar_paths() {
    for name in [
        "glass_of_water_nested",
        "glass_ice_bubbles",
        "deep_nesting",
        "nested_spheres_a",
        "nested_spheres_b",
    ] {
        let mut s = scene(name);
        assert!(!s.solids.is_empty(), "{name}");
        let scalar = pixels(&s, Shading::Scalar);
        let vector = pixels(&s, Shading::Vector);
        let right = differing(&scalar, &vector);
        let eight = differing(&scalar, &pixels_in(&s, Shading::Vector, PacketWidth::Eight));
        s.bsdf_variant = BsdfVariant::WrongNestedPair;
        let pair = differing(&scalar, &pixels(&s, Shading::Vector));
        assert_eq!(differing(&scalar, &pixels(&s, Shading::Scalar)), 0.0, "{name}");
        s.bsdf_variant = BsdfVariant::WrongNestedList;
        let list = differing(&scalar, &pixels(&s, Shading::Vector));
        eprintln!(
            "{name}: pixels differing from scalar shading: vector {right:.4} (packets of 8 {eight:.4}), \
             index pairs against the ambient medium {pair:.4}, lists kept through boundaries {list:.4}"
        );
        assert!(right <= LIMIT && eight <= LIMIT, "{name}: {right}, {eight}");
        assert!(list > LIMIT, "{name}: lists kept through boundaries pass: {list}");
        // The nested spheres have the ambient index (only their absorption
        // shows the rule): no index pair can be wrong there.
        if !name.starts_with("nested_spheres") {
            assert!(pair > LIMIT, "{name}: the ambient index pair passes: {pair}");
        }
    }
}

/// Every kind of light next-event estimation samples, drawn per lane before
/// the kernel weighs it: a spot light, emitting spheres, cylinders and a
/// rectangle (lamps), a sky's sun and a constant sky (the mirage twins
/// without their field), and point, directional, disk, cylinder and quad
/// lights together in one room.
#[test]
fn vector_shading_under_every_light_kind_gives_the_scalar_paths() {
    // A room lit by a point light, a directional light, an emitting
    // cylinder, a disk and a tilted two-sided textured quad: five lights to
    // choose among.
    let lights = format!(
        "{}{}{}",
        super::light_tests::ANALYTIC,
        super::light_tests::SCALED_QUAD,
        r#"
[[lights]]
type = "point"
position = [0.5, 1.5, 0.8]
intensity = [2.0, 2.0, 2.0]
[[lights]]
type = "directional"
direction = [-0.3, -1.0, -0.4]
irradiance = [0.5, 0.5, 0.4]
"#
    );
    let room = || super::light_tests::room(&lights);
    for name in [
        "lamps",
        "desert_sun_nofield",
        "superior_mirage_nofield",
        "heat_shimmer_nofield",
        "room",
    ] {
        let mut s = if name == "room" { room() } else { scene(name) };
        let scalar = pixels(&s, Shading::Scalar);
        let right = differing(&scalar, &pixels(&s, Shading::Vector));
        let eight = differing(&scalar, &pixels_in(&s, Shading::Vector, PacketWidth::Eight));
        s.bsdf_variant = BsdfVariant::WrongNeeCosine;
        let cosine = differing(&scalar, &pixels(&s, Shading::Vector));
        assert_eq!(differing(&scalar, &pixels(&s, Shading::Scalar)), 0.0, "{name}");
        s.bsdf_variant = BsdfVariant::WrongMisPdf;
        let mis = differing(&scalar, &pixels(&s, Shading::Vector));
        eprintln!(
            "{name}: pixels differing from scalar shading: vector {right:.4} (packets of 8 {eight:.4}), \
             no cosine at the point {cosine:.4}, doubled bounce density in MIS {mis:.4}"
        );
        assert!(right <= LIMIT && eight <= LIMIT, "{name}: {right}, {eight}");
        assert!(
            cosine > LIMIT,
            "{name}: next-event estimation without its cosine passes: {cosine}"
        );
        // The sun's disk is so small that the bounce's density hardly
        // weighs against it; the area lights' MIS is tested.
        if name == "lamps" || name == "room" {
            assert!(mis > LIMIT, "{name}: the wrong MIS passes: {mis}");
        }
    }
}

/// Rough glass (GGX) in the kernel: frosted_glass_of_water's rough glass
/// holds water (a nested solid in a rough solid), and a rough-glass ball
/// under a rectangle (its light's connections pass through the surface).
#[test]
fn vector_shading_of_rough_glass_gives_the_scalar_paths() {
    for name in ["frosted_glass_of_water", "rough_ball"] {
        let mut s = if name == "rough_ball" {
            let mut s = scene("three_spheres");
            let glass = s
                .geoms
                .iter()
                .position(|g| g.material.is_dielectric())
                .expect("a glass sphere");
            let distribution =
                crate::bsdf::MicrofacetDistribution::try_new(crate::bsdf::MicrofacetKind::Ggx, 0.3, 0.1)
                    .expect("roughness");
            s.geoms[glass].material = crate::scene::Material::RoughInterface {
                int_ior: 1.5,
                ext_ior: 1.0,
                distribution,
            };
            s
        } else {
            scene(name)
        };
        let scalar = pixels(&s, Shading::Scalar);
        let right = differing(&scalar, &pixels(&s, Shading::Vector));
        let eight = differing(&scalar, &pixels_in(&s, Shading::Vector, PacketWidth::Eight));
        s.bsdf_variant = BsdfVariant::WrongRoughFresnel;
        let half = differing(&scalar, &pixels(&s, Shading::Vector));
        assert_eq!(differing(&scalar, &pixels(&s, Shading::Scalar)), 0.0, "{name}");
        eprintln!(
            "{name}: pixels differing from scalar shading: vector {right:.4} (packets of 8 {eight:.4}), \
             half the Fresnel reflectance at rough facets {half:.4}"
        );
        assert!(right <= LIMIT && eight <= LIMIT, "{name}: {right}, {eight}");
        assert!(
            half > LIMIT,
            "{name}: half the Fresnel reflectance passes: {half}"
        );
    }
}

/// Metals in the kernel: three_spheres with a smooth gold sphere, a rough
/// (GGX, anisotropic) copper one, one-sided, and a mirror.
#[test]
fn vector_shading_of_metals_gives_the_scalar_paths() {
    use crate::bsdf::{Conductor, MicrofacetDistribution, MicrofacetKind, RoughConductor};
    let mut s = scene("three_spheres");
    let glass: Vec<usize> = (0..s.geoms.len())
        .filter(|&g| s.geoms[g].material.is_dielectric())
        .collect();
    assert!(glass.len() >= 2);
    s.geoms[glass[0]].material = crate::scene::Material::Conductor {
        bsdf: Conductor::from_metal("Au", glam::Vec3::ONE).expect("gold"),
        two_sided: false,
    };
    let distribution = MicrofacetDistribution::try_new(MicrofacetKind::Ggx, 0.2, 0.4).expect("roughness");
    s.geoms[glass[1]].material = crate::scene::Material::RoughConductor {
        bsdf: RoughConductor::from_metal(distribution, "Cu", glam::Vec3::ONE).expect("copper"),
        two_sided: false,
    };
    if let Some(&g) = glass.get(2) {
        s.geoms[g].material = crate::scene::Material::Mirror {
            reflectance: glam::Vec3A::new(0.9, 0.8, 0.7),
        };
    }
    let scalar = pixels(&s, Shading::Scalar);
    let right = differing(&scalar, &pixels(&s, Shading::Vector));
    let eight = differing(&scalar, &pixels_in(&s, Shading::Vector, PacketWidth::Eight));
    s.bsdf_variant = BsdfVariant::WrongMetalFresnel;
    let dielectric = differing(&scalar, &pixels(&s, Shading::Vector));
    assert_eq!(differing(&scalar, &pixels(&s, Shading::Scalar)), 0.0);
    eprintln!(
        "metals: pixels differing from scalar shading: vector {right:.4} (packets of 8 {eight:.4}), \
         Fresnel without absorption {dielectric:.4}"
    );
    assert!(right <= LIMIT && eight <= LIMIT, "{right}, {eight}");
    assert!(
        dielectric > LIMIT,
        "Fresnel without absorption passes: {dielectric}"
    );
}

/// Plastics in the kernel: tests/data/plastic_spheres.toml's smooth and GGX
/// rough plastic spheres under its rectangle (which the kernel samples
/// itself), and again with a point light beside it (each lane's light
/// sample drawn before the kernel).
#[test]
fn vector_shading_of_plastics_gives_the_scalar_paths() {
    let path = Path::new("tests/data/plastic_spheres.toml");
    let text = std::fs::read_to_string(path).expect("scene");
    let point = "\n[[lights]]\ntype = \"point\"\nposition = [-1.0, 2.5, 2.0]\nintensity = [3.0, 3.0, 3.0]\n";
    for (name, text) in [("rectangle", text.clone()), ("rectangle and point", text + point)] {
        let load = crate::scene::load_scene_str;
        let mut s = load(
            "plastic_spheres.toml",
            &text,
            Path::new("tests/data"),
            &BuildOptions::default(),
        )
        .expect("scene");
        let scalar = pixels(&s, Shading::Scalar);
        let right = differing(&scalar, &pixels(&s, Shading::Vector));
        let eight = differing(&scalar, &pixels_in(&s, Shading::Vector, PacketWidth::Eight));
        s.bsdf_variant = BsdfVariant::WrongPlasticFresnel;
        let half = differing(&scalar, &pixels(&s, Shading::Vector));
        assert_eq!(differing(&scalar, &pixels(&s, Shading::Scalar)), 0.0, "{name}");
        eprintln!(
            "plastics, {name}: pixels differing from scalar shading: vector {right:.4} (packets of 8 \
             {eight:.4}), half the coating's Fresnel reflectance {half:.4}"
        );
        assert!(right <= LIMIT && eight <= LIMIT, "{name}: {right}, {eight}");
        assert!(
            half > LIMIT,
            "{name}: half the coating's Fresnel reflectance passes: {half}"
        );
    }
}
