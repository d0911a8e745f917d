//! A member's result as bytes and back ([`encode`], [`decode`]): how MPI ranks send results
//! to rank 0. Every `f64` travels as its 8 bytes, so the gathered results are bit for bit
//! what the ranks computed (a decimal text form could round).

use std::collections::BTreeMap;

use super::member::{MemberResult, MemberRun};
use crate::simulate::Failure;

struct Writer(Vec<u8>);

impl Writer {
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    fn str(&mut self, s: &str) {
        self.u64(s.len() as u64);
        self.0.extend_from_slice(s.as_bytes());
    }
    fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for x in v {
            self.f64(*x);
        }
    }
    fn opt_f64(&mut self, v: Option<f64>) {
        self.u64(u64::from(v.is_some()));
        self.f64(v.unwrap_or(0.0));
    }
    fn opt_str(&mut self, v: Option<&str>) {
        self.u64(u64::from(v.is_some()));
        self.str(v.unwrap_or(""));
    }
}

struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn u64(&mut self) -> Option<u64> {
        let (head, rest) = self.0.split_first_chunk::<8>()?;
        self.0 = rest;
        Some(u64::from_le_bytes(*head))
    }
    fn usize(&mut self) -> Option<usize> {
        usize::try_from(self.u64()?).ok()
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_bits(self.u64()?))
    }
    fn str(&mut self) -> Option<String> {
        let n = self.usize()?;
        if n > self.0.len() {
            return None;
        }
        let (s, rest) = self.0.split_at(n);
        self.0 = rest;
        String::from_utf8(s.to_vec()).ok()
    }
    fn f64s(&mut self) -> Option<Vec<f64>> {
        let n = self.usize()?;
        if n > self.0.len() / 8 {
            return None;
        }
        (0..n).map(|_| self.f64()).collect()
    }
    fn opt_f64(&mut self) -> Option<Option<f64>> {
        let some = self.u64()? == 1;
        let v = self.f64()?;
        Some(some.then_some(v))
    }
    fn opt_str(&mut self) -> Option<Option<String>> {
        let some = self.u64()? == 1;
        let v = self.str()?;
        Some(some.then_some(v))
    }
}

/// Appends `results` to `out` as bytes.
pub fn encode(results: &[MemberResult], out: &mut Vec<u8>) {
    let mut w = Writer(std::mem::take(out));
    w.u64(results.len() as u64);
    for r in results {
        w.u64(r.index as u64);
        w.u64(r.params.len() as u64);
        for (k, v) in &r.params {
            w.str(k);
            w.f64(*v);
        }
        w.u64(u64::from(r.start.is_some()));
        w.f64s(r.start.as_deref().unwrap_or(&[]));
        w.opt_str(r.not_run.as_deref());
        w.u64(u64::from(r.skipped));
        w.u64(r.runs.len() as u64);
        for run in &r.runs {
            w.str(&run.method);
            w.u64(run.steps as u64);
            w.f64(run.t_end);
            w.f64s(&run.end);
            w.f64(run.energy_error);
            w.u64(run.fallback_steps as u64);
            w.u64(u64::from(run.failure.is_some()));
            w.u64(run.failure.as_ref().map_or(0, |f| f.step as u64));
            w.str(run.failure.as_ref().map_or("", |f| f.reason.as_str()));
            w.opt_f64(run.megno);
            w.opt_f64(run.lyapunov);
            w.opt_f64(run.sali);
            w.u64(run.crossings.len() as u64);
            for c in &run.crossings {
                w.u64(c.len() as u64);
                for &(t, x, y) in c {
                    w.f64(t);
                    w.f64(x);
                    w.f64(y);
                }
            }
        }
    }
    *out = w.0;
}

/// The results [`encode`] wrote, or `None` for bytes it did not write.
pub fn decode(bytes: &[u8]) -> Option<Vec<MemberResult>> {
    let mut r = Reader(bytes);
    let n = r.usize()?;
    let mut out = Vec::new();
    for _ in 0..n {
        let index = r.usize()?;
        let mut params = BTreeMap::new();
        for _ in 0..r.usize()? {
            let k = r.str()?;
            params.insert(k, r.f64()?);
        }
        let has_start = r.u64()? == 1;
        let start = r.f64s()?;
        let not_run = r.opt_str()?;
        let skipped = r.u64()? == 1;
        let mut runs = Vec::new();
        for _ in 0..r.usize()? {
            let method = r.str()?;
            let steps = r.usize()?;
            let t_end = r.f64()?;
            let end = r.f64s()?;
            let energy_error = r.f64()?;
            let fallback_steps = r.usize()?;
            let failed = r.u64()? == 1;
            let step = r.usize()?;
            let reason = r.str()?;
            let megno = r.opt_f64()?;
            let lyapunov = r.opt_f64()?;
            let sali = r.opt_f64()?;
            let mut crossings = Vec::new();
            for _ in 0..r.usize()? {
                let mut c = Vec::new();
                for _ in 0..r.usize()? {
                    c.push((r.f64()?, r.f64()?, r.f64()?));
                }
                crossings.push(c);
            }
            runs.push(MemberRun {
                method,
                steps,
                t_end,
                end,
                energy_error,
                fallback_steps,
                failure: failed.then_some(Failure { step, reason }),
                megno,
                lyapunov,
                sali,
                crossings,
            });
        }
        out.push(MemberResult {
            index,
            params,
            start: has_start.then_some(start),
            not_run,
            skipped,
            runs,
        });
    }
    r.0.is_empty().then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_back_bit_for_bit() {
        let results = vec![
            MemberResult {
                index: 3,
                params: BTreeMap::from([("k".to_string(), 0.1 + 0.2)]),
                start: Some(vec![1.0 / 3.0, -0.0, f64::MIN_POSITIVE]),
                not_run: None,
                skipped: false,
                runs: vec![MemberRun {
                    method: "dth".into(),
                    steps: 7,
                    t_end: std::f64::consts::PI,
                    end: vec![f64::NAN, 2.0e-300],
                    energy_error: 1.1e-16,
                    fallback_steps: 5,
                    failure: Some(Failure {
                        step: 8,
                        reason: "Newton did not converge".into(),
                    }),
                    megno: Some(2.0000000000000004),
                    lyapunov: None,
                    sali: Some(1e-300),
                    crossings: vec![vec![(1.0, 2.0, 3.0)], Vec::new()],
                }],
            },
            MemberResult {
                index: 4,
                params: BTreeMap::new(),
                start: None,
                not_run: Some("no real p1".into()),
                skipped: true,
                runs: Vec::new(),
            },
        ];
        let mut bytes = Vec::new();
        encode(&results, &mut bytes);
        let back = decode(&bytes).unwrap();
        // Compare bits (NaN != NaN as a float).
        let bits = |r: &[MemberResult]| {
            format!(
                "{:?}",
                r.iter()
                    .map(|m| (
                        m.index,
                        m.params.values().map(|v| v.to_bits()).collect::<Vec<_>>(),
                        m.start
                            .as_ref()
                            .map(|s| s.iter().map(|v| v.to_bits()).collect::<Vec<_>>()),
                        m.runs
                            .iter()
                            .map(|r| (
                                r.end.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                                r.megno.map(f64::to_bits),
                                r.failure.clone(),
                                r.fallback_steps,
                                r.crossings.clone()
                            ))
                            .collect::<Vec<_>>(),
                        m.skipped,
                        m.not_run.clone()
                    ))
                    .collect::<Vec<_>>()
            )
        };
        assert_eq!(bits(&back), bits(&results));
        assert!(decode(&bytes[..bytes.len() - 1]).is_none());
    }
}
