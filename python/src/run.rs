//! Long work (a scene's intersection structure, a technique's preparation, a render) runs on
//! a thread of its own while the calling Python thread watches it: it hands the progress and
//! the film after each pass to the caller's callback, checks for Ctrl-C
//! (`Python::check_signals`) and cancels through the library's cancel token. The callback
//! and the signal check run on the calling thread, as a notebook expects.

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyBool;
use raylink::{Control, Image, Progress};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often the watching thread looks at the work: a cancel from Ctrl-C or a callback is
/// seen within this, and the work stops within a fraction of a second after it.
const POLL: Duration = Duration::from_millis(20);
/// The most often a callback hears of progress between passes.
const TICK: Duration = Duration::from_millis(100);

/// An image as a float32 NumPy array of `height` × `width` × 3, top row first.
pub fn to_array<'py>(py: Python<'py>, image: &Image) -> Bound<'py, PyArray3<f32>> {
    let data: Vec<f32> = image.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    Array3::from_shape_vec((image.height as usize, image.width as usize, 3), data)
        .expect("an image holds width x height pixels")
        .into_pyarray(py)
}

/// A single-valued image (each pixel holds its value in every channel) as a float32 NumPy
/// array of `height` × `width`.
pub fn to_array2<'py>(py: Python<'py>, image: &Image) -> Bound<'py, PyArray2<f32>> {
    let data: Vec<f32> = image.pixels.iter().map(|p| p.x).collect();
    Array2::from_shape_vec((image.height as usize, image.width as usize), data)
        .expect("an image holds width x height pixels")
        .into_pyarray(py)
}

/// What the work has told so far, read by the watching thread.
#[derive(Default)]
struct State {
    phase: String,
    done: u64,
    total: Option<u64>,
    changed: bool,
    warnings: Vec<String>,
}

/// The library's progress sink for one piece of work.
#[derive(Default)]
pub struct Reporter(Mutex<State>);

impl Reporter {
    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Progress for Reporter {
    fn begin(&self, phase: &str, total: Option<u64>, _unit: &str) {
        let mut s = self.state();
        s.phase = phase.to_string();
        s.total = total;
        s.done = 0;
        s.changed = true;
    }

    fn advance(&self, units: u64) {
        let mut s = self.state();
        s.done += units;
        s.changed = true;
    }

    fn warn(&self, line: &str) {
        self.state().warnings.push(line.to_string());
    }
}

/// The film after a pass of a progressive render.
pub struct Pass {
    pub image: Image,
    pub spp: u32,
}

/// What a progress callback is given.
#[pyclass(frozen, get_all, module = "raylink")]
pub struct ProgressEvent {
    /// The phase: "building", "overture", "preprocess", "distribution", "render", ...
    phase: String,
    /// Units of the phase done (tiles, passes, nodes: the library's own units).
    done: u64,
    /// Units in the phase, if known.
    total: Option<u64>,
    /// After a whole pass of a progressive render: the samples per pixel so far.
    spp: Option<u32>,
    /// After a whole pass: the image so far (float32, height x width x 3).
    image: Option<Py<PyArray3<f32>>>,
    /// Seconds since the work started.
    elapsed: f64,
}

#[pymethods]
impl ProgressEvent {
    fn __repr__(&self) -> String {
        let total = self.total.map_or("?".into(), |t| t.to_string());
        match self.spp {
            Some(spp) => format!("ProgressEvent(phase={:?}, spp={spp})", self.phase),
            None => format!(
                "ProgressEvent(phase={:?}, done={}/{total})",
                self.phase, self.done
            ),
        }
    }
}

/// A control for one piece of work: its own cancel token, `budget`, and `reporter`.
pub fn control(budget: raylink::MemoryBudget, reporter: &Arc<Reporter>) -> Control {
    Control {
        cancel: raylink::CancelToken::new(),
        budget,
        progress: reporter.clone(),
    }
}

/// Runs `work` on its own thread until it returns, watching it from this one: every pass in
/// `passes` and, at most every [`TICK`], the progress go to `callback` (a `False` from it
/// cancels the work, which then returns what it finished); Ctrl-C cancels it and raises
/// `KeyboardInterrupt` once it has stopped, as does an exception from the callback; the
/// library's warnings become Python warnings.
pub fn drive<T: Send>(
    py: Python<'_>,
    callback: Option<&Bound<'_, PyAny>>,
    control: &Control,
    reporter: &Reporter,
    passes: Receiver<Pass>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let start = Instant::now();
    std::thread::scope(|scope| {
        let worker = scope.spawn(work);
        let mut failure: Option<PyErr> = None;
        // Whether the callback still hears of the work: not once it has cancelled it.
        let mut listening = callback.is_some();
        let mut last_tick = Instant::now();
        loop {
            let finished = worker.is_finished();
            while let Ok(pass) = passes.try_recv() {
                if let (Some(cb), true) = (callback, listening) {
                    let event = ProgressEvent {
                        phase: "render".into(),
                        done: pass.spp as u64,
                        total: None,
                        spp: Some(pass.spp),
                        image: Some(to_array(py, &pass.image).unbind()),
                        elapsed: start.elapsed().as_secs_f64(),
                    };
                    listening = answer(cb.call1((event,)), control, &mut failure);
                }
            }
            let (event, warnings) = {
                let mut s = reporter.state();
                let warnings = std::mem::take(&mut s.warnings);
                let due = s.changed && (finished || last_tick.elapsed() >= TICK);
                let event = due.then(|| {
                    s.changed = false;
                    ProgressEvent {
                        phase: s.phase.clone(),
                        done: s.done,
                        total: s.total,
                        spp: None,
                        image: None,
                        elapsed: start.elapsed().as_secs_f64(),
                    }
                });
                (event, warnings)
            };
            for w in warnings {
                let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
                if let Err(e) = PyErr::warn(py, &category, &std::ffi::CString::new(w)?, 1) {
                    stop(e, control, &mut failure);
                }
            }
            if let (Some(cb), Some(event), true) = (callback, event, listening) {
                last_tick = Instant::now();
                listening = answer(cb.call1((event,)), control, &mut failure);
            }
            if failure.is_none() {
                if let Err(e) = py.check_signals() {
                    stop(e, control, &mut failure);
                }
            }
            if finished {
                break;
            }
            py.detach(|| std::thread::sleep(POLL));
        }
        let result = match worker.join() {
            Ok(result) => result,
            Err(panic) => std::panic::resume_unwind(panic),
        };
        match failure {
            Some(e) => Err(e),
            None => Ok(result),
        }
    })
}

/// Cancels the work, keeping the first error to raise once it has stopped.
fn stop(e: PyErr, control: &Control, failure: &mut Option<PyErr>) {
    control.cancel.cancel();
    failure.get_or_insert(e);
}

/// What a callback's return means: `False` cancels; an exception cancels and is raised.
/// Whether the callback is to hear more (not once it has cancelled).
fn answer(
    returned: PyResult<Bound<'_, PyAny>>,
    control: &Control,
    failure: &mut Option<PyErr>,
) -> bool {
    match returned {
        Ok(v) if v.is_instance_of::<PyBool>() && !v.is_truthy().unwrap_or(true) => {
            control.cancel.cancel();
            false
        }
        Ok(_) => true,
        Err(e) => {
            stop(e, control, failure);
            false
        }
    }
}

/// A channel for the passes of a render (its sender goes to the render's watch).
pub fn passes() -> (Sender<Pass>, Receiver<Pass>) {
    std::sync::mpsc::channel()
}
