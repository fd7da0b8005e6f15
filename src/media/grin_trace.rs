//! `snell grin-trace`: single rays in an unbounded field, no surfaces. JSON in, JSON
//! out. A malformed document is an error; a bad query only sets its own `status`.
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::field::IndexField;
use super::stepper::{State, Stepper};
use super::{check_method, exact, mirage_study, MediumError, Method};

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct Input {
    queries: Vec<serde_json::Value>,
}

/// Where a query stops: the plane x = X, or after an arc length S.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Stop {
    /// Stop where the ray crosses the world plane x = X (metres, finite).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<f64>,
    /// Stop after this arc length, metres (finite, >= 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub s: Option<f64>,
}

/// One query.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Query {
    /// Name of the query, copied to its answer.
    pub id: String,
    /// The index field, unbounded (no box, no surfaces).
    pub field: IndexField,
    /// Launch point, world metres.
    pub start: DVec3,
    /// Launch direction (non-zero; normalised).
    pub direction: DVec3,
    /// Where the trace ends: exactly one of `x` and `s`.
    pub stop: Stop,
    /// How the ray equation is integrated (exact: linear fields; paper methods:
    /// stratified fields).
    pub method: Method,
    /// rk45 error tolerance (metres per step); default 1e-9.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    /// Step (metres) of the fixed-step methods (default 0.01 when `steps` is absent too).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<f64>,
    /// Number of steps instead of `step`: step = (straight distance to the stop)/steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps: Option<u64>,
    /// Give up after this arc length (default 1e6 m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_length: Option<f64>,
}

impl Query {
    /// A query stopping at arc length `len` (the accuracy bench and `snell report`).
    pub fn along(
        field: &IndexField,
        start: DVec3,
        direction: DVec3,
        len: f64,
        method: Method,
        tolerance: f64,
        step: f64,
    ) -> Query {
        Query {
            id: String::new(),
            field: field.clone(),
            start,
            direction,
            stop: Stop {
                x: None,
                s: Some(len),
            },
            method,
            tolerance: Some(tolerance),
            step: Some(step),
            steps: None,
            max_length: None,
        }
    }
}

/// A point where the height component of the direction changes sign.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
pub struct Extremum {
    /// The turning point, world metres.
    pub position: DVec3,
    /// Arc length from the start to it, metres.
    pub arc_length: f64,
}

/// One result.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct Answer {
    /// The query's `id`.
    pub id: String,
    /// "ok", or why the query failed as `queries[i].key: message` (then the
    /// optional fields below are absent).
    pub status: String,
    /// The method used (absent when the query itself did not parse).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<Method>,
    /// End point, world metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end: Option<DVec3>,
    /// Unit tangent at the end point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_direction: Option<DVec3>,
    /// Arc length from the start to the end point, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arc_length: Option<f64>,
    /// Turning points along the way, in order.
    #[serde(default)]
    pub extrema: Vec<Extremum>,
    /// Field evaluations (n and ∇n at one point count as one).
    pub evaluations: u64,
    /// Steps (or pieces) taken.
    pub steps: u64,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
struct Output {
    results: Vec<Answer>,
}

/// The core of `snell grin-trace`: the pretty JSON `{"results": [...]}`.
///
/// `input` is `{"queries": [...]}`; every query gets one answer, in order, and
/// a query that is malformed or fails only sets its own `status`.
///
/// # Errors
///
/// [`MediumError::Invalid`] at `(document)` when `input` is not a JSON object
/// with a `queries` array (and at `(output)` if the answers cannot be
/// serialised).
pub fn grin_trace_json(input: &str) -> Result<String, MediumError> {
    let doc: Input = serde_json::from_str(input)
        .map_err(|e| MediumError::invalid("(document)", format!("expected {{\"queries\": [...]}} ({e})")))?;
    let mut used = 0u64;
    let results = doc
        .queries
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let id = v
                .get("id")
                .and_then(|x| x.as_str())
                .map_or_else(|| format!("#{i}"), str::to_owned);
            let fail = |status: String| Answer {
                id: id.clone(),
                status,
                method: None,
                end: None,
                end_direction: None,
                arc_length: None,
                extrema: Vec::new(),
                evaluations: 0,
                steps: 0,
            };
            let left = DOCUMENT_WORK.saturating_sub(used);
            if left == 0 {
                return fail(format!(
                    "queries[{i}]: work limit: the document's {DOCUMENT_WORK} steps + evaluations were used by the queries before this one"
                ));
            }
            let mut budget = WorkBudget::new(left);
            let answer = match serde_json::from_value::<Query>(v.clone()) {
                Err(e) => fail(format!("queries[{i}]: {e}")),
                Ok(q) => match trace_within(&q, &mut budget) {
                    Ok(a) => a,
                    Err(e) => {
                        let mut a = fail(format!("queries[{i}].{e}"));
                        a.method = Some(q.method);
                        a
                    }
                },
            };
            used += budget.done.max(answer.evaluations + answer.steps);
            answer
        })
        .collect();
    serde_json::to_string_pretty(&Output { results })
        .map_err(|e| MediumError::invalid("(output)", e.to_string()))
}

fn finite_vec(key: &str, v: DVec3) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{key}: expected three finite numbers, got {v:?}"))
    }
}

/// Work limits of one query: a query that would need more is refused (before
/// it starts when the step count is known, else when it gets there), so no
/// query runs for more than a fraction of a second.
pub const MAX_STEPS: u64 = 2_000_000;
/// Field evaluations one query may use (see [`MAX_STEPS`]).
pub const MAX_EVALUATIONS: u64 = 10_000_000;
/// Work (steps + evaluations) of a whole document: a document of many heavy
/// queries stops there (the later queries get a work-limit status).
pub const DOCUMENT_WORK: u64 = 20_000_000;

/// The work (steps + field evaluations) one query may do, and has done: a
/// document gives each query what its earlier queries left.
#[derive(Debug, Clone, Copy)]
struct WorkBudget {
    /// Work the query may do.
    left: u64,
    /// Work the query has done, as of its last check.
    done: u64,
}

impl WorkBudget {
    fn new(left: u64) -> Self {
        WorkBudget { left, done: 0 }
    }
}

/// Where a trace ends (one of `stop_x`, `stop_s`; or `max_len`), and which
/// way is up (for its turning points).
struct Goal {
    stop_x: Option<f64>,
    stop_s: Option<f64>,
    max_len: f64,
    up: DVec3,
}

/// What a trace has found and spent so far.
struct Walk<'a> {
    /// Turning points, in order.
    extrema: Vec<Extremum>,
    /// Steps (or pieces) taken.
    steps: u64,
    /// The query's budget, told the work done at every check.
    budget: &'a mut WorkBudget,
}

impl Walk<'_> {
    /// Before another step: `Err` when the steps, `evals` field
    /// evaluations, or both together exceed their limits or the budget.
    fn check_work(&mut self, evals: u64) -> Result<(), String> {
        let steps = self.steps;
        self.budget.done = steps + evals;
        if steps > MAX_STEPS || evals > MAX_EVALUATIONS || steps + evals > self.budget.left {
            return Err(format!(
                "work limit: {steps} steps and {evals} field evaluations without reaching the stop (limits {MAX_STEPS} steps, {MAX_EVALUATIONS} evaluations, {DOCUMENT_WORK} steps + evaluations per document): {}",
                "loosen tolerance, enlarge step or shorten the stop"
            ));
        }
        Ok(())
    }
}

/// Traces one query (errors are "key: message" relative to the query).
///
/// # Errors
///
/// `key: message` for an invalid parameter (`field…`, `method`, `start`,
/// `direction`, `stop`, `tolerance`, `step`, `max_length`), for n not finite or
/// not > 0 along the ray, a paper method's failure (e.g. at a turning point),
/// a work limit ([`MAX_STEPS`], [`MAX_EVALUATIONS`]), or a stop not reached
/// within `max_length`.
pub fn trace(q: &Query) -> Result<Answer, String> {
    trace_within(q, &mut WorkBudget::new(u64::MAX))
}

/// [`trace`] within `budget`, which learns the work done.
fn trace_within(q: &Query, budget: &mut WorkBudget) -> Result<Answer, String> {
    let field = q.field.validated("field").map_err(|e| e.to_string())?;
    check_method(&field, q.method, "method").map_err(|e| e.to_string())?;
    finite_vec("start", q.start)?;
    finite_vec("direction", q.direction)?;
    if q.direction.length().is_nan() || q.direction.length() <= 0.0 {
        return Err("direction: expected a non-zero vector".into());
    }
    let d = q.direction.normalize();
    let max_len = q.max_length.unwrap_or(1e6);
    if !(max_len.is_finite() && max_len > 0.0) {
        return Err(format!("max_length: expected a finite number > 0, got {max_len}"));
    }
    let (stop_x, stop_s) = match (q.stop.x, q.stop.s) {
        (Some(x), None) if x.is_finite() => (Some(x), None),
        (None, Some(s)) if s.is_finite() && s >= 0.0 => (None, Some(s)),
        _ => {
            return Err(format!(
                "stop: expected exactly one of {{\"x\": finite X}} or {{\"s\": finite S ≥ 0}}, got {:?}",
                q.stop
            ))
        }
    };
    let tol = q.tolerance.unwrap_or(1e-9);
    if !(tol.is_finite() && tol > 0.0) {
        return Err(format!("tolerance: expected a finite number > 0, got {tol}"));
    }
    let straight = match (stop_x, stop_s) {
        (_, Some(s)) => s,
        (Some(x), _) => ((x - q.start.x) / d.x).abs(),
        _ => 0.0,
    };
    let step = match (q.step, q.steps) {
        (Some(h), None) => h,
        (None, Some(k)) if k > 0 => straight / k as f64,
        (None, None) => 0.01,
        _ => return Err("step/steps: expected one of step (> 0 m) or steps (> 0)".into()),
    };
    if !(step.is_finite() && step > 0.0) {
        return Err(format!("step: expected a finite step > 0, got {step}"));
    }
    if q.method != Method::Rk45 && q.method != Method::Exact {
        // Fixed steps: the count is known up front (the x stop along the straight line).
        let length = stop_s.unwrap_or(straight.min(max_len));
        let planned = length / step;
        if planned > MAX_STEPS as f64 {
            return Err(format!(
                "step: {length:.3e} m in steps of {step:.3e} m would take {planned:.2e} steps (limit {MAX_STEPS}): enlarge step"
            ));
        }
    }
    let goal = Goal {
        stop_x,
        stop_s,
        max_len,
        up: field.strata().map_or(DVec3::Y, |s| s.up),
    };
    let mut stepper = Stepper::new(&field, q.method, tol, step);
    let mut evals = 0u64;
    let start = State::new(&field, q.start, d, &mut evals).map_err(|e| format!("start: {e}"))?;
    let mut walk = Walk {
        extrema: Vec::new(),
        steps: 0,
        budget,
    };
    let end = if q.method == Method::Exact {
        trace_exact(&field, &start, &goal, &mut walk)?
    } else if q.method.is_paper() {
        trace_paper(&mut stepper, &start, &goal, &mut walk)?
    } else {
        trace_ode(&mut stepper, &start, &goal, &mut walk)?
    };
    Ok(Answer {
        id: q.id.clone(),
        status: "ok".into(),
        method: Some(q.method),
        end: Some(end.r),
        end_direction: Some(end.t),
        arc_length: Some(end.s),
        extrema: walk.extrema,
        evaluations: evals + stepper.evals + u64::from(q.method == Method::Exact),
        steps: walk.steps.max(1),
    })
}

fn trace_exact(field: &IndexField, st: &State, goal: &Goal, walk: &mut Walk<'_>) -> Result<State, String> {
    let &Goal {
        stop_x,
        stop_s,
        max_len,
        up,
    } = goal;
    let (m, _) = exact::linear_params(field).ok_or("method: exact needs a linear field")?;
    let tau_end = if let Some(s) = stop_s {
        exact::tau_for_length(m, up, st, s)
    } else {
        let x = stop_x.unwrap_or(0.0);
        if up.x.abs() > 1e-15 {
            return Err("stop: exact with an x stop needs `up` perpendicular to x".into());
        }
        let vx = st.v.x;
        let tau = (x - st.r.x) / vx;
        if !(tau >= 0.0 && tau.is_finite()) {
            return Err(format!(
                "stop: the ray never reaches x = {x} (it moves along x at {:.3e})",
                st.t.x
            ));
        }
        tau
    };
    let (r, v, s) = exact::at_tau(m, up, st, tau_end);
    if s > max_len {
        return Err(format!("stop: not reached within max_length {max_len} m"));
    }
    if let Some(tau) = exact::turning_tau(m, up, st) {
        if tau <= tau_end {
            let (p, _, sa) = exact::at_tau(m, up, st, tau);
            walk.extrema.push(Extremum {
                position: p,
                arc_length: sa,
            });
        }
    }
    let (n, g) = field.eval(r);
    super::stepper::check_n(n, r)?;
    Ok(State {
        r,
        t: v.normalize(),
        v,
        n,
        g,
        s,
    })
}

/// Root of `f` on (0, h) by the Illinois method; f(0) and f(h) have opposite signs.
fn root<F: FnMut(f64) -> Result<f64, String>>(
    mut f: F,
    h: f64,
    f0: f64,
    fh: f64,
    tol: f64,
) -> Result<f64, String> {
    let (mut a, mut b, mut fa, mut fb) = (0.0, h, f0, fh);
    let mut side = 0;
    let mut c = 0.5 * h;
    for _ in 0..100 {
        c = if fb != fa {
            b - fb * (b - a) / (fb - fa)
        } else {
            0.5 * (a + b)
        };
        if !(c > a.min(b) && c < a.max(b)) {
            c = 0.5 * (a + b);
        }
        let fc = f(c)?;
        if fc == 0.0 || (b - a).abs() < tol {
            break;
        }
        if (fc > 0.0) == (fb > 0.0) {
            b = c;
            fb = fc;
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        } else {
            a = c;
            fa = fc;
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        }
    }
    Ok(c)
}

fn trace_ode(
    stepper: &mut Stepper<'_>,
    st: &State,
    goal: &Goal,
    walk: &mut Walk<'_>,
) -> Result<State, String> {
    let &Goal {
        stop_x,
        stop_s,
        max_len,
        up,
    } = goal;
    let limit = stop_s.unwrap_or(max_len);
    let tol = stepper.tolerance;
    let mut cur = *st;
    let mut h_next = (tol.powf(0.2) * 0.1).max(1e-6);
    loop {
        let rest = limit - cur.s;
        if rest <= 0.0 {
            if stop_s.is_some() {
                return Ok(cur);
            }
            return Err(format!(
                "stop: x = {} not reached within {max_len} m of arc",
                stop_x.unwrap_or(0.0)
            ));
        }
        walk.check_work(stepper.evals)?;
        let (next, h) = if stepper.method == Method::Rk45 {
            stepper.rk45_step(&cur, &mut h_next, rest)?
        } else {
            let h = stepper.step.min(rest);
            (stepper.rk4(&cur, h)?, h)
        };
        walk.steps += 1;
        let next = if h >= rest {
            State { s: limit, ..next }
        } else {
            next
        };
        let rtol = tol * 1e-3;
        let (va, vb) = (cur.t.dot(up), next.t.dot(up));
        if va != 0.0 && (va > 0.0) != (vb > 0.0) {
            let base = cur;
            let sig = root(|s| Ok(stepper.single(&base, s)?.t.dot(up)), h, va, vb, rtol)?;
            let p = stepper.single(&base, sig)?;
            walk.extrema.push(Extremum {
                position: p.r,
                arc_length: p.s,
            });
        }
        if let Some(x) = stop_x {
            let (fa, fb) = (cur.r.x - x, next.r.x - x);
            if fa == 0.0 {
                return Ok(cur);
            }
            if (fa > 0.0) != (fb > 0.0) || fb == 0.0 {
                let base = cur;
                let sig = root(|s| Ok(stepper.single(&base, s)?.r.x - x), h, fa, fb, rtol)?;
                let mut p = stepper.single(&base, sig)?;
                p.r.x = x;
                return Ok(p);
            }
        }
        cur = next;
    }
}

fn trace_paper(
    stepper: &mut Stepper<'_>,
    st: &State,
    goal: &Goal,
    walk: &mut Walk<'_>,
) -> Result<State, String> {
    let &Goal {
        stop_x,
        stop_s,
        max_len,
        up,
    } = goal;
    let limit = stop_s.unwrap_or(max_len);
    let mut cur = *st;
    loop {
        if cur.s >= limit {
            if stop_s.is_some() {
                return Ok(cur);
            }
            return Err(format!(
                "stop: x = {} not reached within {max_len} m of arc",
                stop_x.unwrap_or(0.0)
            ));
        }
        walk.check_work(stepper.evals)?;
        let seg = mirage_study::segment(
            stepper.field,
            stepper.method,
            stepper.step,
            &cur,
            &mut stepper.evals,
        )?;
        walk.steps += 1;
        let next = match seg {
            mirage_study::Seg::To(n) => n,
            mirage_study::Seg::Forever => {
                // Horizontal: straight forever. Go to the stop along the line.
                let len = match stop_x {
                    Some(x) if cur.t.x != 0.0 && (x - cur.r.x) / cur.t.x >= 0.0 => (x - cur.r.x) / cur.t.x,
                    Some(_) => {
                        return Err(
                            "stop: never reached (the method keeps the ray horizontal and straight)".into(),
                        )
                    }
                    None => limit - cur.s,
                };
                let mut n = cur;
                n.r += cur.t * len;
                n.s += len;
                return Ok(n);
            }
        };
        let seg_len = next.s - cur.s;
        let dir = (next.r - cur.r) / seg_len;
        let (va, vb) = (cur.t.dot(up), next.t.dot(up));
        if va != 0.0 && (va > 0.0) != (vb > 0.0) {
            // The vertex furthest along the old vertical direction.
            let p = if (cur.r.dot(up) - next.r.dot(up)) * va.signum() > 0.0 {
                cur
            } else {
                next
            };
            walk.extrema.push(Extremum {
                position: p.r,
                arc_length: p.s,
            });
        }
        if let Some(x) = stop_x {
            let (fa, fb) = (cur.r.x - x, next.r.x - x);
            if (fa > 0.0) != (fb > 0.0) || fb == 0.0 {
                let u = fa / (fa - fb) * seg_len;
                let mut p = cur;
                p.r = cur.r + dir * u;
                p.r.x = x;
                p.t = dir;
                p.s = cur.s + u;
                return Ok(p);
            }
        }
        if next.s > limit {
            let u = limit - cur.s;
            let mut p = cur;
            p.r = cur.r + dir * u;
            p.t = dir;
            p.s = limit;
            return Ok(p);
        }
        cur = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An rk4 query of 1 m in steps of 1 mm through a linear field: a
    /// thousand steps of four evaluations.
    fn query() -> Query {
        let field = IndexField::Linear {
            n0: 1.0,
            m: -0.01,
            up: DVec3::Y,
            base: 0.0,
        };
        Query::along(&field, DVec3::ZERO, DVec3::X, 1.0, Method::Rk4, 1e-9, 1e-3)
    }

    /// A query's budget bounds it and learns the work done; the budget is
    /// the caller's, so a later trace of the same query (here, on the same
    /// thread) is not bounded by it.
    #[test]
    fn a_budget_bounds_its_own_query_only() {
        let mut budget = WorkBudget::new(500);
        let e = trace_within(&query(), &mut budget).unwrap_err();
        assert!(e.contains("work limit"), "{e}");
        assert!(budget.done > 500 && budget.done < 600, "{budget:?}");
        let a = trace(&query()).unwrap();
        assert_eq!(a.steps, 1000);
        assert!(a.evaluations + a.steps > 500);
        let mut roomy = WorkBudget::new(u64::MAX);
        let b = trace_within(&query(), &mut roomy).unwrap();
        assert_eq!(b, a);
        assert!(
            roomy.done > 0 && roomy.done <= a.evaluations + a.steps,
            "{roomy:?} {a:?}"
        );
    }
}
