//! FrameStats as Python values: one dict per frame, or one array per field.

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::FrameStats;

/// One field of FrameStats, typed.
pub enum Value {
    /// Seconds or a length.
    F(f64),
    /// A count.
    U(u64),
    /// Sensor-gated only: did the sensor trigger (None for other methods).
    B(Option<bool>),
}

/// Every FrameStats field by name, plus `total_time`, in a fixed order.
pub fn fields(s: &FrameStats) -> Vec<(&'static str, Value)> {
    use Value::*;
    vec![
        ("total_time", F(s.total_time())),
        ("refit_time", F(s.refit_time)),
        ("traverse_time", F(s.traverse_time)),
        ("sensor_time", F(s.sensor_time)),
        ("node_pairs", U(s.node_pairs)),
        ("self_culls", U(s.self_culls)),
        ("pair_culls", U(s.pair_culls)),
        ("contour_tests", U(s.contour_tests)),
        ("contour_fails", U(s.contour_fails)),
        ("certificates_reused", U(s.certificates_reused)),
        ("certificates_rechecked", U(s.certificates_rechecked)),
        ("slab_culls", U(s.slab_culls)),
        ("adjacent_skips", U(s.adjacent_skips)),
        ("front_jobs", U(s.front_jobs)),
        ("front_skips", U(s.front_skips)),
        ("primitive_tests", U(s.primitive_tests)),
        ("filter_decisions", U(s.filter_decisions)),
        ("proximity_tests", U(s.proximity_tests)),
        ("contacts", U(s.contacts)),
        ("proximity_contacts", U(s.proximity_contacts)),
        ("candidate_builds", U(s.candidate_builds)),
        ("candidate_reuses", U(s.candidate_reuses)),
        ("proximity_one_shots", U(s.proximity_one_shots)),
        ("candidates", U(s.candidates)),
        ("continuous_repeats", U(s.continuous_repeats)),
        ("continuous_from_proximity", U(s.continuous_from_proximity)),
        ("triggered", B(s.triggered)),
        ("relax_steps", U(s.relax_steps as u64)),
        ("moving_particles", U(s.moving_particles as u64)),
        ("closest_sl", F(s.closest_sl)),
        ("closest_odl", F(s.closest_odl)),
    ]
}

/// One frame's stats as a dict (`triggered` is None unless the method has a sensor).
pub fn stats_dict<'py>(py: Python<'py>, s: &FrameStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in fields(s) {
        match v {
            Value::F(x) => d.set_item(k, x)?,
            Value::U(x) => d.set_item(k, x)?,
            Value::B(x) => d.set_item(k, x)?,
        }
    }
    Ok(d)
}

/// Many frames' stats as a dict of 1-d arrays, one per field: float64 for
/// times and lengths, int64 for counts, int8 for `triggered` (-1: no sensor).
pub fn stats_columns<'py>(py: Python<'py>, frames: &[&FrameStats]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let Some(first) = frames.first() else {
        return Ok(d);
    };
    let rows: Vec<Vec<(&'static str, Value)>> = frames.iter().map(|s| fields(s)).collect();
    for (col, (name, kind)) in fields(first).iter().enumerate() {
        let arr = match kind {
            Value::F(_) => {
                PyArray1::from_vec(py, rows.iter().map(|r| as_f(&r[col].1)).collect()).into_any()
            }
            Value::U(_) => {
                PyArray1::from_vec(py, rows.iter().map(|r| as_i(&r[col].1)).collect()).into_any()
            }
            Value::B(_) => {
                PyArray1::from_vec(py, rows.iter().map(|r| tri_state(&r[col].1)).collect())
                    .into_any()
            }
        };
        d.set_item(*name, arr)?;
    }
    Ok(d)
}

fn as_f(v: &Value) -> f64 {
    match v {
        Value::F(x) => *x,
        Value::U(x) => *x as f64,
        Value::B(_) => f64::NAN,
    }
}

fn as_i(v: &Value) -> i64 {
    match v {
        Value::U(x) => *x as i64,
        _ => 0,
    }
}

fn tri_state(v: &Value) -> i8 {
    match v {
        Value::B(Some(true)) => 1,
        Value::B(Some(false)) => 0,
        _ => -1,
    }
}

/// Field names of a struct from its derived `Debug` output (`Name { a: .., b: .. }`),
/// so tests can check that the bindings export every field the engine has.
#[cfg(test)]
pub fn debug_field_names(debug: &str) -> Vec<String> {
    let body =
        &debug[debug.find('{').map_or(0, |i| i + 1)..debug.rfind('}').unwrap_or(debug.len())];
    let mut names = Vec::new();
    let mut depth = 0;
    let mut token = String::new();
    for c in body.chars() {
        match c {
            '{' | '(' | '[' => depth += 1,
            '}' | ')' | ']' => depth -= 1,
            ':' if depth == 0 && !token.trim().is_empty() => {
                names.push(token.trim().trim_start_matches(',').trim().to_string());
                token.clear();
            }
            ',' if depth == 0 => token.clear(),
            _ if depth == 0 => token.push(c),
            _ => {}
        }
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_frame_stats_field_is_exported() {
        let engine = debug_field_names(&format!("{:?}", FrameStats::default()));
        let ours: Vec<&str> = fields(&FrameStats::default())
            .iter()
            .map(|(k, _)| *k)
            .collect();
        assert!(engine.len() > 10, "parsed {engine:?}");
        for name in &engine {
            assert!(
                ours.contains(&name.as_str()),
                "FrameStats.{name} is not exported by stats::fields"
            );
        }
    }
}
