//! Plug-ins written in Python. [`PyRule`] implements the core's `contract::rules::plugin::
//! RulePlugin` for a Python aggregation rule (integers in, integers out, like the built-in
//! rules; asked by every node's contract and by every fold of the log).
//!
//! Plug-in attacks written in Python: [`PyAttack`] implements the core's
//! `byzantine::Attack` for a Python callable (the adapter `swarmfl.plugins` builds around the
//! user's class), so that a Python attack runs through the same interface as the built-in
//! ones: asked on the driver thread, in robot order, with the robot's own node's view.
//!
//! A plug-in that raises or answers something the contract cannot take (wrong length or type,
//! NaN, a negative sample count) does not crash: its first error is kept, the plug-in is not
//! asked again, and the run stops before its next record is written; the Python function that
//! ran it then raises that error (a `swarmfl.PluginError` naming the plug-in, the round and the
//! robot, with the plug-in's traceback as its cause).

use std::sync::{Arc, Mutex};

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyTuple};
use swarmfl_core::byzantine::plugin::{PluginId, Plugins};
use swarmfl_core::byzantine::{Action, Attack, View};
use swarmfl_core::contract::rules::plugin::RulePlugin;
use swarmfl_core::contract::rules::Input;
use swarmfl_core::rng::Rng;
use swarmfl_core::types::Digest;

/// The first error of the plug-ins of one run (shared by the agents and the run's check).
pub type Failure = Arc<Mutex<Option<PyErr>>>;

/// A Python attack as the core's `Attack`.
pub struct PyAttack {
    /// `call(view: dict) -> None | (bytes, int)`: `swarmfl.plugins`' adapter around the class.
    call: Py<PyAny>,
    failure: Failure,
}

/// A plug-in as the Python side hands it over: (name, what was hashed, its source, the
/// adapter to call).
pub type Arg = Option<(String, String, String, Py<PyAny>)>;

/// A Python aggregation rule as the core's `RulePlugin`.
pub struct PyRule {
    /// `call(current: bytes, models: bytes, n: int, samples: list, f: int) -> bytes`:
    /// `swarmfl.plugins`' adapter around the user's rule (models as little-endian `i64`).
    call: Py<PyAny>,
    failure: Failure,
}

impl PyRule {
    fn ask(
        &self,
        py: Python<'_>,
        current: &[i64],
        inputs: &[Input],
        f: usize,
    ) -> PyResult<Vec<i64>> {
        let cur: Vec<u8> = current.iter().flat_map(|w| w.to_le_bytes()).collect();
        let models: Vec<u8> = inputs
            .iter()
            .flat_map(|s| s.weights.iter().flat_map(|w| w.to_le_bytes()))
            .collect();
        let samples: Vec<u64> = inputs.iter().map(|s| s.samples).collect();
        let answer = self.call.call1(
            py,
            (
                PyBytes::new(py, &cur),
                PyBytes::new(py, &models),
                inputs.len(),
                PyList::new(py, samples)?,
                f,
            ),
        )?;
        let bytes: Vec<u8> = answer.bind(py).extract()?;
        if bytes.len() != 8 * current.len() {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "plug-in rule answered {} weights, the model has {}",
                bytes.len() / 8,
                current.len()
            )));
        }
        Ok(bytes
            .chunks_exact(8)
            .map(|c| i64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
            .collect())
    }
}

impl RulePlugin for PyRule {
    fn aggregate(&self, current: &[i64], inputs: &[Input], f: usize) -> Result<Vec<i64>, String> {
        let mut failure = self.failure.lock().unwrap_or_else(|p| p.into_inner());
        if failure.is_some() {
            // The run stops before its next record: the answer no longer matters.
            return Err("the plug-in rule failed earlier".into());
        }
        match Python::attach(|py| self.ask(py, current, inputs, f)) {
            Ok(weights) => Ok(weights),
            Err(e) => {
                let text = e.to_string();
                *failure = Some(e);
                Err(text)
            }
        }
    }
}

/// The plug-ins of a run offered `attack` and `rule` (each `(name, what was hashed, source,
/// adapter)`), and the slot their first error goes to. The rule is registered with the
/// core's plug-in rules from here on (see `Plugins::add_rule`).
pub fn plugins(attack: Arg, rule: Arg) -> (Plugins, Failure) {
    let failure: Failure = Arc::new(Mutex::new(None));
    let mut plugins = Plugins::none();
    if let Some((name, what, source, call)) = rule {
        let digest = Digest::of(source.as_bytes()).to_hex();
        let agent = PyRule {
            call,
            failure: failure.clone(),
        };
        plugins.add_rule(PluginId::rule(&name, &digest, &what), Arc::new(agent));
    }
    if let Some((name, what, source, call)) = attack {
        let digest = Digest::of(source.as_bytes()).to_hex();
        let agent = PyAttack {
            call,
            failure: failure.clone(),
        };
        plugins.add_attack(PluginId::attack(&name, &digest, &what), Arc::new(agent));
    }
    (plugins, failure)
}

/// The plug-ins' first error, taken out of `failure`.
pub fn take_failure(failure: &Failure) -> Option<PyErr> {
    failure.lock().unwrap_or_else(|p| p.into_inner()).take()
}

/// Whether a plug-in failed (the run's check stops the run then).
pub fn failed(failure: &Failure) -> bool {
    failure.lock().unwrap_or_else(|p| p.into_inner()).is_some()
}

fn f32_bytes<'py>(py: Python<'py>, values: &[f32]) -> Bound<'py, PyBytes> {
    let v: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
    PyBytes::new(py, &v)
}

impl PyAttack {
    /// The view as the adapter takes it: numbers, and models as little-endian `f32` bytes.
    fn view_dict<'py>(
        &self,
        py: Python<'py>,
        view: &View,
        rng: &mut Rng,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("robot", view.robot)?;
        d.set_item("round", view.chain.round)?;
        d.set_item("now_ms", view.now_ms)?;
        d.set_item("last_chance", view.last_chance)?;
        d.set_item("weight_scale", view.weight_scale)?;
        d.set_item("threshold", view.threshold())?;
        d.set_item("input_waypoints", view.input_waypoints)?;
        d.set_item("claimed_samples", view.config.claimed_samples)?;
        d.set_item("claim_bound", view.params.claim_bound.max_samples)?;
        let config = serde_json::to_string(view.config)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
        d.set_item("config_json", config)?;
        // One draw of the robot's Byzantine stream of this phase: the plug-in's own seed.
        d.set_item("seed", rng.next_u64())?;
        d.set_item("shared", f32_bytes(py, &view.shared()))?;
        match view.previous() {
            Some(p) => d.set_item("previous", f32_bytes(py, &p))?,
            None => d.set_item("previous", py.None())?,
        }
        d.set_item("coalition", PyList::new(py, view.coalition)?)?;
        let subs = PyList::empty(py);
        for s in &view.chain.submissions {
            let weights = swarmfl_core::learn::from_fixed(&s.weights, view.weight_scale);
            let byzantine = view
                .coalition
                .get(s.sender as usize)
                .copied()
                .unwrap_or(false);
            let outlier = s.verdict != swarmfl_core::contract::Verdict::Accepted;
            subs.append((
                s.sender,
                s.samples,
                outlier,
                byzantine,
                f32_bytes(py, &weights),
            ))?;
        }
        d.set_item("submissions", subs)?;
        let dataset = view.own_dataset();
        let points: Vec<f32> = dataset
            .iter()
            .flat_map(|s| s.points.iter().flat_map(|p| [p[0], p[1]]))
            .collect();
        d.set_item("sample_count", dataset.len())?;
        d.set_item("samples", f32_bytes(py, &points))?;
        Ok(d)
    }

    /// Asks the adapter and checks its answer (the adapter checks it first, with the plug-in's
    /// name in its messages; this is the last line, so that nothing unchecked reaches the core).
    fn ask(&self, py: Python<'_>, view: &View, rng: &mut Rng) -> PyResult<Action> {
        let d = self.view_dict(py, view, rng)?;
        let answer = self.call.call1(py, (d,))?;
        let answer = answer.bind(py);
        if answer.is_none() {
            return Ok(Action::Wait);
        }
        let bad = |what: String| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "plug-in attack answered {what} in round {} for robot {}",
                view.chain.round, view.robot
            ))
        };
        let tuple = answer
            .cast::<PyTuple>()
            .map_err(|_| bad("something other than None or (weights, samples)".into()))?;
        if tuple.len() != 2 {
            return Err(bad(format!("a tuple of {} items", tuple.len())));
        }
        let bytes: Vec<u8> = tuple.get_item(0)?.extract()?;
        let samples: u64 = tuple.get_item(1)?.extract()?;
        let len = view.chain.weights.len();
        if bytes.len() != 4 * len {
            return Err(bad(format!(
                "{} weights, the model has {len}",
                bytes.len() / 4
            )));
        }
        let weights: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if let Some(i) = weights.iter().position(|w| !w.is_finite()) {
            return Err(bad(format!("weight {i} = {}", weights[i])));
        }
        let samples = u32::try_from(samples)
            .map_err(|_| bad(format!("{samples} samples (at most {})", u32::MAX)))?;
        Ok(Action::Submit { weights, samples })
    }
}

impl Attack for PyAttack {
    fn act(&self, view: &View, rng: &mut Rng) -> Action {
        let mut failure = self.failure.lock().unwrap_or_else(|p| p.into_inner());
        if failure.is_some() {
            // The run stops before its next record: the answer no longer matters.
            return Action::Wait;
        }
        match Python::attach(|py| self.ask(py, view, rng)) {
            Ok(action) => action,
            Err(e) => {
                *failure = Some(e);
                Action::Wait
            }
        }
    }
}
