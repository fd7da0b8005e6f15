//! How big a report's measurements are: `--quick` (seconds, run by the tests)
//! or full (minutes).

/// Sizes of one run (quick or full).
pub(crate) struct Sizes {
    pub conv: (u32, u32, &'static [u32], u32),
    pub nested_reps: usize,
    pub nested_grid: (u32, u32),
    pub nested_render: (u32, u32, u32),
    pub audit_rays: u64,
    pub grin_full: bool,
    pub chord: [(&'static str, u32, u32, &'static [f64]); 3],
    pub warp_film: (u32, u32),
    pub warp_vertices: &'static [usize],
    pub warp_films: &'static [(u32, u32)],
    pub warp_sweep_vertices: usize,
    pub warp_reps: usize,
    pub pictures: (u32, u32, u32),
}

pub(crate) const QUICK: Sizes = Sizes {
    conv: (64, 48, &[4, 8, 16, 32, 64], 512),
    nested_reps: 3,
    nested_grid: (24, 18),
    nested_render: (48, 36, 2),
    audit_rays: 2_000,
    grin_full: false,
    chord: [
        ("mirage_road", 64, 24, &[1.0, 0.1, 0.01, 0.001]),
        ("mirage_sea", 64, 32, &[3.0, 0.3, 0.03, 0.003]),
        ("heat_shimmer", 32, 24, &[0.01, 0.003, 0.001, 0.0003]),
    ],
    warp_film: (96, 72),
    warp_vertices: &[1_000, 4_000],
    warp_films: &[(64, 48), (128, 96)],
    warp_sweep_vertices: 2_000,
    warp_reps: 1,
    pictures: (64, 48, 4),
};

pub(crate) const FULL: Sizes = Sizes {
    conv: (192, 144, &[4, 8, 16, 32, 64, 128, 256], 2048),
    nested_reps: 5,
    nested_grid: (160, 120),
    nested_render: (160, 120, 8),
    audit_rays: 100_000,
    grin_full: true,
    chord: [
        (
            "mirage_road",
            240,
            80,
            &[1.0, 0.3, 0.1, 0.03, 0.01, 0.003, 0.0003],
        ),
        ("mirage_sea", 240, 120, &[3.0, 0.3, 0.03, 0.003, 0.0003]),
        ("heat_shimmer", 120, 90, &[0.01, 0.003, 0.001, 0.0003, 0.0001]),
    ],
    warp_film: (640, 480),
    warp_vertices: &[25_000, 50_000, 100_000, 200_000],
    warp_films: &[(320, 240), (640, 480), (1024, 768)],
    warp_sweep_vertices: 100_000,
    warp_reps: 3,
    pictures: (320, 240, 64),
};
