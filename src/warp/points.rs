//! `snell warp-points`: JSON in, JSON out (format in docs/warp.md). `method`
//! is "exact" or "paper" (the paper's C→B→A for the cylinder; for the plate
//! the paper's formula is the exact one). A bad
//! point gets an error status and does not sink the batch; a bad document is
//! one clear error naming the key.
use super::{CylStatus, Family, HollowCylinder, Plate, PlateStatus};
use glam::DVec3;
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Query {
    eye: [f64; 3],
    glass: GlassDesc,
    #[serde(default = "exact")]
    method: String,
    points: Vec<[f64; 3]>,
}

fn exact() -> String {
    "exact".into()
}

#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
enum GlassDesc {
    Plate {
        near_face_point: [f64; 3],
        normal: [f64; 3],
        thickness: f64,
        ior: f64,
    },
    HollowCylinder {
        axis_point: [f64; 3],
        axis_direction: [f64; 3],
        outer_radius: f64,
        inner_radius: f64,
        ior: f64,
    },
}

fn v(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

/// Run a warp-points document; `file` names it in errors.
pub fn warp_points_json(file: &str, input: &str) -> Result<String, String> {
    let q: Query =
        serde_json::from_str(input).map_err(|e| format!("{file}:{}:{}: {e}", e.line(), e.column()))?;
    let paper = match q.method.as_str() {
        "exact" => false,
        "paper" => true,
        o => {
            return Err(format!(
                "{file}: method: expected \"exact\" or \"paper\", got \"{o}\""
            ))
        }
    };
    let eye = v(q.eye);
    if !eye.is_finite() {
        return Err(format!("{file}: eye: expected finite coordinates"));
    }
    enum Glass {
        Plate(Plate),
        Cyl(HollowCylinder),
    }
    let glass = match q.glass {
        GlassDesc::Plate {
            near_face_point,
            normal,
            thickness,
            ior,
        } => Glass::Plate(
            Plate::try_new(v(near_face_point), v(normal), thickness, ior)
                .map_err(|e| format!("{file}: glass.{e}"))?,
        ),
        GlassDesc::HollowCylinder {
            axis_point,
            axis_direction,
            outer_radius,
            inner_radius,
            ior,
        } => Glass::Cyl(
            HollowCylinder::try_new(v(axis_point), v(axis_direction), outer_radius, inner_radius, ior)
                .map_err(|e| format!("{file}: glass.{e}"))?,
        ),
    };
    let mut results = Vec::with_capacity(q.points.len());
    for (i, pt) in q.points.iter().enumerate() {
        let p = v(*pt);
        if !p.is_finite() {
            results.push(serde_json::json!({"index": i, "status": "error: point has non-finite coordinates", "images": []}));
            continue;
        }
        let (status, images) = match &glass {
            Glass::Plate(pl) => match pl.warp(eye, p) {
                Ok(im) => (
                    "ok".to_string(),
                    vec![serde_json::json!({"family": Family::Wall2, "direction": im.eye_dir.to_array(), "position": im.position.to_array(), "refractions": 2, "parity": 1})],
                ),
                Err(PlateStatus::InFront) => (
                    "ok".to_string(),
                    vec![serde_json::json!({"family": Family::Direct, "direction": (p - eye).normalize_or_zero().to_array(), "position": p.to_array(), "refractions": 0, "parity": 1})],
                ),
                Err(PlateStatus::InsideGlass) => ("error: the point is inside the glass".into(), vec![]),
                Err(PlateStatus::EyeNotInFront) => ("error: the eye is not in front of the plate".into(), vec![]),
                Err(PlateStatus::NotConverged) => ("error: the solver did not converge".into(), vec![]),
            },
            Glass::Cyl(c) => match if paper {
                super::approx_tube::approx_tube_image(c, eye, p).map(|o| o.into_iter().collect())
            } else {
                c.images(eye, p)
            } {
                Ok(ims) => (
                    if ims.is_empty() { "ok: no image".to_string() } else { "ok".to_string() },
                    ims.iter()
                        .map(|im| serde_json::json!({"family": im.family, "direction": im.direction.to_array(), "position": im.position.to_array(), "refractions": im.refractions, "parity": im.parity}))
                        .collect(),
                ),
                Err(CylStatus::InsideGlass) => ("error: the point is inside the glass wall".into(), vec![]),
                Err(CylStatus::EyeNotOutside) => ("error: the eye is not outside the tube".into(), vec![]),
            },
        };
        results.push(serde_json::json!({"index": i, "target": pt, "status": status, "images": images}));
    }
    serde_json::to_string_pretty(&serde_json::json!({"method": q.method, "points": results}))
        .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batch_with_good_and_bad_points() {
        let doc = r#"{"eye": [0, 0, 4],
            "glass": {"kind": "hollow_cylinder", "axis_point": [0, 0, 0], "axis_direction": [0, 1, 0],
                      "outer_radius": 1.0, "inner_radius": 0.8, "ior": 1.5},
            "method": "exact",
            "points": [[0.5, 0, -2.5], [0, 0.5, -4], [0.9, 0, 0]]}"#;
        let out: serde_json::Value = serde_json::from_str(&warp_points_json("q.json", doc).unwrap()).unwrap();
        let pts = out["points"].as_array().unwrap();
        assert_eq!(pts.len(), 3);
        assert_eq!(pts[0]["status"], "ok");
        assert!(!pts[0]["images"].as_array().unwrap().is_empty());
        assert!(pts[2]["status"].as_str().unwrap().contains("inside the glass"));
        let paper = doc.replace("\"exact\"", "\"paper\"");
        let out: serde_json::Value =
            serde_json::from_str(&warp_points_json("q.json", &paper).unwrap()).unwrap();
        assert_eq!(out["points"][0]["images"].as_array().unwrap().len(), 1);
        let e = warp_points_json("q.json", &doc.replace("\"exact\"", "\"magic\"")).unwrap_err();
        assert!(e.contains("method"), "{e}");
        let bad = doc.replace("\"ior\": 1.5", "\"ior\": 1.5, \"colour\": 1");
        let e = warp_points_json("q.json", &bad).unwrap_err();
        assert!(e.contains("q.json:") && e.contains("colour"), "{e}");
        let plate = r#"{"eye": [0, 0, 0], "glass": {"kind": "plate", "near_face_point": [0, 0, -1], "normal": [0, 0, -1], "thickness": 0.2, "ior": 1.5}, "points": [[0, 0, -3], [0, 0, -0.5]]}"#;
        let out: serde_json::Value =
            serde_json::from_str(&warp_points_json("p.json", plate).unwrap()).unwrap();
        let z = out["points"][0]["images"][0]["position"][2].as_f64().unwrap();
        assert!((z - (-3.0 + 0.2 * (1.0 - 1.0 / 1.5))).abs() < 1e-12);
        assert_eq!(out["points"][1]["images"][0]["family"], "direct");
    }
}
