//! [`Trajectory`]: a stored DTH run (midpoints, vertices, multipliers, times, Newton counts).

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};
use std::io::{self, Write};

use crate::observer::{DthRecord, Observer, StepKind, StepRecord};

/// A DTH trajectory with `N` midpoints and (once the run has finished) `N + 1` vertices.
///
/// It is an [`Observer`]: pass it to [`Dth::run`](super::Dth::run), or get one from
/// [`Dth::trajectory`](super::Dth::trajectory) / [`integrate`](super::integrate). It stores
/// DTH records only: a fixed-step method's records (no [`StepRecord::dth`]) are skipped, so
/// record those with [`Recorder`](crate::observer::Recorder).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    midpoints: Vec<OVector<f64, D>>,
    lambdas: Vec<f64>,
    midpoint_times: Vec<f64>,
    vertices: Vec<OVector<f64, D>>,
    vertex_times: Vec<f64>,
    psis: Vec<f64>,
    iterations: Vec<u32>,
    factorizations: Vec<u32>,
    closed: bool,
    ks: Vec<usize>,
    kinds: Vec<StepKind>,
}

impl<D: Dim> Trajectory<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// An empty trajectory.
    pub fn new() -> Self {
        Trajectory {
            midpoints: Vec::new(),
            lambdas: Vec::new(),
            midpoint_times: Vec::new(),
            vertices: Vec::new(),
            vertex_times: Vec::new(),
            psis: Vec::new(),
            iterations: Vec::new(),
            factorizations: Vec::new(),
            closed: false,
            ks: Vec::new(),
            kinds: Vec::new(),
        }
    }
    /// Number of midpoints `N`.
    pub fn len(&self) -> usize {
        self.midpoints.len()
    }
    /// `true` when no midpoint is stored.
    pub fn is_empty(&self) -> bool {
        self.midpoints.is_empty()
    }
    /// Midpoints `zbar_0 .. zbar_{N-1}`.
    pub fn midpoints(&self) -> &[OVector<f64, D>] {
        &self.midpoints
    }
    /// Multipliers `lambda_0 .. lambda_{N-1}`.
    pub fn lambdas(&self) -> &[f64] {
        &self.lambdas
    }
    /// Midpoint times `tbar_0 .. tbar_{N-1}`.
    pub fn midpoint_times(&self) -> &[f64] {
        &self.midpoint_times
    }
    /// Vertices `z^(0) .. z^(N)` (`z^(k)` is the left vertex of segment `k`; the last is the
    /// right vertex of the last segment). `N + 1` entries after a run has finished.
    pub fn vertices(&self) -> &[OVector<f64, D>] {
        &self.vertices
    }
    /// Vertex times `t^(0) .. t^(N)`.
    pub fn vertex_times(&self) -> &[f64] {
        &self.vertex_times
    }
    /// `Psi(zbar_k)` at each midpoint.
    pub fn psis(&self) -> &[f64] {
        &self.psis
    }
    /// Newton iterations of each midpoint (0 for the initial one; outer iterations for the
    /// nested solver).
    pub fn iterations(&self) -> &[u32] {
        &self.iterations
    }
    /// LU factorizations of each midpoint.
    pub fn factorizations(&self) -> &[u32] {
        &self.factorizations
    }
    /// Midpoint indices `k` of the stored midpoints (consecutive unless some steps were run
    /// with another observer).
    pub fn ks(&self) -> &[usize] {
        &self.ks
    }
    /// What produced each stored midpoint: [`StepKind::Fallback`] marks the robust mode's
    /// non-DTH steps.
    pub fn kinds(&self) -> &[StepKind] {
        &self.kinds
    }
    /// Number of stored steps that were not DTH steps (robust-mode fallback steps).
    pub fn fallback_steps(&self) -> usize {
        self.kinds
            .iter()
            .filter(|k| **k == StepKind::Fallback)
            .count()
    }
    /// The record of the `index`-th stored midpoint.
    pub fn record(&self, index: usize) -> Option<StepRecord<D>> {
        Some(StepRecord {
            k: *self.ks.get(index)?,
            t: self.midpoint_times[index],
            z: self.midpoints[index].clone(),
            kind: self.kinds[index],
            iterations: self.iterations[index],
            factorizations: self.factorizations[index],
            dth: Some(DthRecord {
                lambda: self.lambdas[index],
                vertex: self.vertices[index].clone(),
                vertex_time: self.vertex_times[index],
                psi: self.psis[index],
            }),
        })
    }
    /// The record of midpoint `k`, if stored.
    pub fn get(&self, k: usize) -> Option<StepRecord<D>> {
        self.record(self.ks.binary_search(&k).ok()?)
    }
    /// Iterate over the per-midpoint records.
    pub fn iter(&self) -> impl Iterator<Item = StepRecord<D>> + '_ {
        (0..self.len()).filter_map(move |i| self.record(i))
    }

    /// Write the midpoints as CSV: `k,tbar,lambda,zbar_1..zbar_D,t_vertex,vertex_1..vertex_D,
    /// psi,iterations,kind`, one line per midpoint, with a header (`kind` is `dth`, `fallback`
    /// or `shortened`).
    pub fn write_csv<W: Write>(&self, mut out: W) -> io::Result<()> {
        // The dimension: the type's when fixed, else the stored states'.
        let dim = D::try_to_usize()
            .or_else(|| self.midpoints.first().map(|z| z.len()))
            .unwrap_or(0);
        write!(out, "k,tbar,lambda")?;
        for i in 1..=dim {
            write!(out, ",zbar_{i}")?;
        }
        write!(out, ",t_vertex")?;
        for i in 1..=dim {
            write!(out, ",vertex_{i}")?;
        }
        writeln!(out, ",psi,iterations,kind")?;
        for i in 0..self.len() {
            write!(
                out,
                "{},{:e},{:e}",
                self.ks[i], self.midpoint_times[i], self.lambdas[i]
            )?;
            for x in self.midpoints[i].iter() {
                write!(out, ",{x:e}")?;
            }
            write!(out, ",{:e}", self.vertex_times[i])?;
            for x in self.vertices[i].iter() {
                write!(out, ",{x:e}")?;
            }
            let kind = match self.kinds[i] {
                StepKind::Fallback => "fallback",
                StepKind::Shortened => "shortened",
                _ => "dth",
            };
            writeln!(out, ",{:e},{},{kind}", self.psis[i], self.iterations[i])?;
        }
        Ok(())
    }
}

impl<D: Dim> Observer<D> for Trajectory<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Stores a DTH record; records without DTH data (a fixed-step method's, see
    /// [`Recorder`](crate::observer::Recorder)) are not part of a DTH trajectory and are skipped.
    fn on_step(&mut self, r: &StepRecord<D>) {
        let Some(d) = &r.dth else { return };
        if self.closed {
            // The stored right end of the previous run is this segment's left vertex.
            self.vertices.pop();
            self.vertex_times.pop();
            self.closed = false;
        }
        self.ks.push(r.k);
        self.midpoints.push(r.z.clone());
        self.lambdas.push(d.lambda);
        self.midpoint_times.push(r.t);
        self.vertices.push(d.vertex.clone());
        self.vertex_times.push(d.vertex_time);
        self.psis.push(d.psi);
        self.iterations.push(r.iterations);
        self.factorizations.push(r.factorizations);
        self.kinds.push(r.kind);
    }
    fn on_finish(&mut self, last_vertex: &OVector<f64, D>, last_vertex_time: f64) {
        if !self.closed && !self.midpoints.is_empty() {
            self.vertices.push(last_vertex.clone());
            self.vertex_times.push(last_vertex_time);
            self.closed = true;
        }
    }
}
