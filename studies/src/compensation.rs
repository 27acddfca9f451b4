//! The second level of a scene with `[control]` and a sampled sensor, in
//! the monolithic model (eq. 7 with the legs driven by the sensor's commands; IJCSA agrees with
//! it within 1e-3 of the peaks, master/tests/cli/feed.rs):
//!
//! * the cabin's motion against the feed's error, uncompensated (sensor off), compensated
//!   (coupled: the platform's reactions act on the cabin) and as a decoupled model predicts it
//!   (the same sensor and commands replayed on the cabin poses of the uncompensated run: the
//!   compensation's reactions never reach the cabin) — `compensation.csv`, `compensation.svg`;
//! * the feed error against the sensor's delay and sample rate, each case marked unstable when
//!   the run stops or its feed error keeps growing — `sweep.csv`, `sweep.svg`;
//! * the error budget: the scene run again without the instrument's noise, without its delay and
//!   with neither (what is left is the filter's lag and the sampling), against the decoupled
//!   prediction (what the coupling adds) — `budget.csv`.
//!
//! Every run is independent: they run in parallel ([`crate::parallel`]).

use anyhow::{Context, bail};
use feedcore::scene::{Scene, ValidScene};
use feedcore::{Quat, Vec3};
use plotters::prelude::*;
use stewart::{Compensation, Stewart};

use crate::limits::{Footprint, Limits, PlanError, check_memory};
use crate::monolithic::Monolithic;
use crate::observe::Observer;
use crate::plot::{Line, PALETTE, Panel, PlotError, stacked};
use crate::points::{Codec, Store};
use crate::table::Table;

/// What the study runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Simulated time of the uncompensated, compensated and decoupled runs and of the budget's, s.
    pub t_end: f64,
    /// Simulated time of each run of the sweep, s.
    pub sweep_t_end: f64,
    /// Sensor delays of the sweep, s.
    pub delays: Vec<f64>,
    /// Sample rates of the sweep, Hz.
    pub rates: Vec<f64>,
    /// The command filter's bandwidth for every run, Hz, instead of the scene's.
    pub bandwidth: Option<f64>,
    /// Worker threads (`None`: one per core).
    pub jobs: Option<usize>,
    pub limits: Limits,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            t_end: 60.0,
            sweep_t_end: 20.0,
            delays: vec![0.0, 0.02, 0.05, 0.1, 0.2, 0.3],
            rates: vec![10.0, 25.0, 50.0, 100.0],
            bandwidth: None,
            jobs: None,
            limits: Limits::default(),
        }
    }
}

/// The largest step: a whole fraction of the sample period, at most T/8 and 2.5 ms.
pub fn step_for(period: f64) -> f64 {
    period / (period / 0.0025 - 1e-9).ceil().max(8.0)
}

/// [`step_for`] the shortest period of a scene's sensor and inertial unit.
pub fn case_step(scene: &ValidScene) -> f64 {
    step_for(scene.control.as_ref().and_then(|c| c.shortest_period()).map_or(f64::NAN, |(t, _)| t))
}

/// The steps of a run over `t_end` at `h`, refused before anything runs when `h` is not a
/// positive finite number or the steps exceed --max-steps, or the model would not fit in memory.
pub fn checked_steps(scene: &ValidScene, h: f64, t_end: f64, what: &str, limits: &Limits) -> anyhow::Result<usize> {
    if !(h > 0.0 && h.is_finite()) {
        bail!("{what}: the step h = {h} s the sensor's rate gives is not a positive finite number");
    }
    if !(t_end > 0.0 && t_end.is_finite()) {
        return Err(PlanError::BadEnd(t_end)).context(what.to_owned());
    }
    let steps = (t_end / h).round();
    if !(steps <= limits.max_steps as f64) {
        return Err(PlanError::TooManySteps { steps, dt: h, t_end, cap: limits.max_steps }).context(what.to_owned());
    }
    check_memory(scene, Footprint::Coupled, 0, limits).context(what.to_owned())?;
    Ok(steps as usize)
}

/// One run of the monolithic model, step by step from the start (t = 0 included, as `master
/// run` counts it): time, |cabin displacement| and |feed error| (mm), and with `replay` the feed
/// error a decoupled model predicts on these cabin poses.
#[derive(Default)]
pub struct History {
    pub t: Vec<f64>,
    pub cabin_mm: Vec<f64>,
    pub feed_mm: Vec<f64>,
    pub replayed_mm: Vec<f64>,
}

/// How much the compensated-to-uncompensated RMS ratio may grow from the middle third of a run to
/// the last before the run counts as unstable (a stable design's ratio moves by ±20 % with the
/// wind's variation; a slowly pumped mode doubles it within minutes).
const GROWTH: f64 = 1.5;

/// RMS of `x` (a series of `h`, every step) over the steps with `from < t ≤ to`.
fn window_rms(h: &History, x: &[f64], from: f64, to: f64) -> f64 {
    let (sum, n) =
        h.t.iter()
            .zip(x)
            .filter(|(t, _)| **t > from && **t <= to + 1e-9)
            .fold((0.0, 0usize), |(s, n), (_, v)| (s + v * v, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

/// RMS and peak of a series (every step).
pub fn rms_peak(x: &[f64]) -> (f64, f64) {
    let rms = (x.iter().map(|e| e * e).sum::<f64>() / x.len().max(1) as f64).sqrt();
    (rms, x.iter().copied().fold(0.0, f64::max))
}

/// Runs `scene` in the monolithic model with step `h` to `t_end`; the feed is placed by `comp`
/// (the scene's own compensation); `replay`: a sampled compensation to replay on the poses.
pub fn history(
    scene: &ValidScene,
    comp: &Compensation,
    h: f64,
    steps: usize,
    replay: Option<&Compensation>,
) -> anyhow::Result<History> {
    let mut m = Monolithic::new(scene)?;
    let mut replayed = replay.map(|c| (c, c.start_state()));
    let mut out = History::default();
    let mut s = m.sample();
    let origin = s.cabin.position;
    let feed = |c: &Compensation, s: &crate::monolithic::Sample, (centre, turn): (&Vec3, &Quat)| {
        let (p, r) = (&s.cabin.position, &s.cabin.orientation);
        c.feed_error(&(p + r * centre), &(r * turn), s.time).0.norm() * 1e3
    };
    for step in 0..=steps {
        if step > 0 {
            crate::cancel::check()?;
            if let Some((c, state)) = replayed.as_mut() {
                state.sample(c, s.time, &s.cabin);
            }
            m.step(h)?;
            s = m.sample();
        }
        out.t.push(s.time);
        out.cabin_mm.push((s.cabin.position - origin).norm() * 1e3);
        out.feed_mm.push(feed(comp, &s, (&s.platform, &s.platform_rotation)));
        if let Some((c, state)) = &replayed {
            let commanded = state.at(c, s.time);
            out.replayed_mm.push(feed(c, &s, (&commanded.position, &commanded.rotation())));
        }
        if !out.feed_mm.last().is_some_and(|e| e.is_finite()) {
            bail!("the feed error is not finite at t = {} s", s.time);
        }
    }
    Ok(out)
}

/// One case of the sweep: whether it stayed stable, and its feed error RMS and peak (mm).
pub struct Verdict {
    pub stable: bool,
    pub rms: f64,
    pub peak: f64,
    pub note: String,
}

impl Verdict {
    /// A compensated run is stable when its feed error does not keep growing — the last
    /// third's peak at most 3× the middle third's, and its RMS against the uncompensated run's
    /// (`off`, over the same time) at most [`GROWTH`] × the middle third's: a lightly damped
    /// mode pumped slowly hides under the wind's own variation otherwise — and its cabin's peak
    /// stays within twice the uncompensated one.
    pub fn judge(r: &History, off: &History) -> Verdict {
        let n = r.feed_mm.len();
        let (rms, peak) = rms_peak(&r.feed_mm);
        let (middle, late) = (rms_peak(&r.feed_mm[n / 3..2 * n / 3]).1, rms_peak(&r.feed_mm[2 * n / 3..]).1);
        let end = r.t.last().copied().unwrap_or(0.0);
        let ratio = |from: f64, to: f64| window_rms(r, &r.feed_mm, from, to) / window_rms(off, &off.feed_mm, from, to);
        let (middle_ratio, late_ratio) = (ratio(end / 3.0, 2.0 * end / 3.0), ratio(2.0 * end / 3.0, end));
        let cabin = rms_peak(&r.cabin_mm).1;
        let off_cabin_peak =
            off.t.iter().zip(&off.cabin_mm).filter(|(t, _)| **t <= end + 1e-9).fold(0.0f64, |m, (_, d)| m.max(*d));
        if late > 3.0 * middle {
            let note = format!("growing: peak {middle:.3} → {late:.3} mm");
            Verdict { stable: false, rms, peak, note }
        } else if late_ratio > GROWTH * middle_ratio {
            let note = format!("growing against the uncompensated run: RMS ratio {middle_ratio:.3} → {late_ratio:.3}");
            Verdict { stable: false, rms, peak, note }
        } else if cabin > 2.0 * off_cabin_peak {
            let note = format!("cabin peak {cabin:.3} mm against {off_cabin_peak:.3} mm uncompensated");
            Verdict { stable: false, rms, peak, note }
        } else {
            Verdict { stable: true, rms, peak, note: String::new() }
        }
    }

    /// A run that stopped.
    pub fn stopped(note: String) -> Verdict {
        Verdict { stable: false, rms: f64::NAN, peak: f64::NAN, note }
    }

    /// As a store's keeps it (the numbers exactly, NaN included).
    fn to_cells(&self) -> Vec<String> {
        vec![self.stable.to_string(), format!("{:?}", self.rms), format!("{:?}", self.peak), self.note.clone()]
    }

    /// The verdict a store's case gives, if it is one a run can give: a stable run's RMS and
    /// peak are finite, an unstable one's finite or (stopped) none.
    fn from_cells(cells: &[String]) -> anyhow::Result<Verdict> {
        let [stable, rms, peak, note] = cells else { bail!("a store's case of {} fields, not 4", cells.len()) };
        let number = |x: &String| -> anyhow::Result<f64> {
            let v: f64 = x.parse().with_context(|| format!("a store's number `{x}`"))?;
            anyhow::ensure!(v.is_nan() || (v.is_finite() && v >= 0.0), "a store's number `{x}`");
            Ok(v)
        };
        let v = Verdict {
            stable: stable.parse().with_context(|| format!("a store's verdict `{stable}`"))?,
            rms: number(rms)?,
            peak: number(peak)?,
            note: note.clone(),
        };
        anyhow::ensure!(!v.stable || (v.rms.is_finite() && v.peak.is_finite()), "a stable case without its error");
        Ok(v)
    }
}

/// A study ready to run: every run's steps and memory checked.
pub struct Study {
    scene: ValidScene,
    /// How messages name the scene (its file).
    shown: String,
    comp: Compensation,
    settings: Settings,
    /// The step of the long runs, s, and their steps.
    pub h: f64,
    steps: usize,
    /// The sweep's cases: rate, delay, the scene at them, steps.
    cases: Vec<(f64, f64, ValidScene, usize)>,
}

/// One line of the error budget: the run, its feed error RMS, the term it measures, and the term.
#[derive(Clone, Debug, PartialEq)]
pub struct BudgetLine {
    pub run: &'static str,
    pub rms: f64,
    pub term: &'static str,
    pub value: f64,
}

/// The study's results.
pub struct Results {
    pub scene: String,
    pub settings: Settings,
    /// The step of the long runs, s, and the scene's sample interval, s.
    pub h: f64,
    sample_interval_s: f64,
    /// The uncompensated run (with the decoupled replay on its poses) and the compensated one.
    pub off: History,
    pub on: History,
    /// The sweep's cases (rate, delay) and their verdicts.
    pub cases: Vec<(f64, f64)>,
    pub verdicts: Vec<Verdict>,
    pub budget: Vec<BudgetLine>,
    /// The budget's runs that stopped: which and why (their term is then NaN).
    pub budget_failures: Vec<String>,
}

impl Study {
    /// The study of `scene` (named `shown` in messages): a sampled sensor needed, every run's
    /// steps and memory checked.
    pub fn new(scene: &ValidScene, shown: &str, settings: Settings) -> anyhow::Result<Study> {
        let mut scene = scene.clone();
        if let Some(b) = settings.bandwidth {
            let with_bandwidth = |s: &mut Scene| {
                if let Some(c) = s.control.as_mut() {
                    c.bandwidth_hz = Some(b);
                }
            };
            scene = scene.edited(with_bandwidth).context("--bandwidth")?;
        }
        let period = match scene.control.as_ref().map(|c| (c.sensor, c.shortest_period())) {
            Some((_, Some((period, _)))) => period,
            Some((sensor, None)) => bail!(
                "{shown}: [control] sensor = {sensor:?}; `master compensation` studies a sampled sensor (set sensor = \"sampled\")"
            ),
            None => bail!("{shown}: the scene has no [control] section (the second level): nothing to compensate"),
        };
        let comp = Stewart::from_scene(&scene)?.compensation().cloned().expect("a scene with [control] has one");
        let h = step_for(period);
        let limits = &settings.limits;
        let steps =
            checked_steps(&scene, h, settings.t_end, &format!("{shown}: the runs over {} s", settings.t_end), limits)?;
        // the sweep: delay × rate, the rest of the scene as it is
        let mut cases = Vec::new();
        for &rate in &settings.rates {
            for &delay in &settings.delays {
                let case = format!("sweep case {rate} Hz, delay {delay} s");
                // the case's own step (the scene's may not take the samples of a faster sensor)
                let at_case = |s: &mut Scene| {
                    if let Some(c) = s.control.as_mut() {
                        (c.sample_rate_hz, c.delay_s) = (Some(rate), delay);
                        if let Some((period, _)) = c.shortest_period() {
                            s.solver.dt_s = step_for(period);
                        }
                    }
                };
                let s = scene.edited(at_case).with_context(|| case.clone())?;
                let steps = checked_steps(&s, case_step(&s), settings.sweep_t_end, &case, limits)?;
                cases.push((rate, delay, s, steps));
            }
        }
        Ok(Study { scene, shown: shown.to_owned(), comp, settings, h, steps, cases })
    }

    /// The scene studied (with the bandwidth the settings give).
    pub fn scene(&self) -> &ValidScene {
        &self.scene
    }

    /// Runs the uncompensated and the compensated run, the budget's runs and the sweep, each set
    /// in parallel; a sweep case `store` holds from an earlier run is taken from there.
    pub fn run(&self, store: &dyn Store, observer: &dyn Observer) -> anyhow::Result<Results> {
        let (scene, comp, h, steps, jobs) = (&self.scene, &self.comp, self.h, self.steps, self.settings.jobs);
        // the uncompensated run (its poses also feed the decoupled replay) and the coupled one
        let off = crate::options::Compensation::Off.apply(scene)?;
        observer.begin(&format!(
            "{}: uncompensated, compensated and decoupled runs over {} s at h = {h} s",
            self.shown, self.settings.t_end
        ));
        let mains = crate::parallel::map_in_order(&[true, false], jobs, |_, &is_off| {
            if is_off { history(&off, comp, h, steps, Some(comp)) } else { history(scene, comp, h, steps, None) }
        })?;
        let mut mains = mains.into_iter();
        let off_run = mains.next().expect("two runs").context("the uncompensated run")?;
        let on_run = mains.next().expect("two runs").context("the compensated run")?;

        // the error budget: the scene with a perfect instrument in turn
        let kinds = [Budget::Noiseless, Budget::Prompt, Budget::Perfect];
        let budget_scenes =
            kinds.map(|b| scene.edited(|s| b.apply(s)).with_context(|| format!("the budget's run {}", b.label())));
        let budget_scenes = budget_scenes.into_iter().collect::<anyhow::Result<Vec<_>>>()?;
        let budget_runs = crate::parallel::map_in_order(&budget_scenes, jobs, |_, s| {
            let c = Stewart::from_scene(s)?.compensation().cloned().expect("a scene with [control] has one");
            history(s, &c, h, steps, None)
        })?;
        // a run that stops (the loop pumped without the instrument's noise) is reported, not fatal
        let mut budget_failures = Vec::new();
        let budget_rms: Vec<f64> = budget_runs
            .into_iter()
            .zip(kinds)
            .map(|(r, b)| match r {
                Ok(r) => rms_peak(&r.feed_mm).0,
                Err(e) => {
                    budget_failures.push(format!("the budget's run {}: {e:#}", b.label()));
                    f64::NAN
                }
            })
            .collect();

        // the sweep: a case is unstable when it stops, when its feed error keeps growing, or when
        // the platform's reactions drive the cabin to more than twice the uncompensated cabin's
        // peak (the cable–cabin modes excited): [`Verdict::judge`]
        let (n, t) = (self.cases.len(), self.settings.sweep_t_end);
        observer.begin(&format!("sweep: {n} runs over {t} s ({} done before)", store.resumed()));
        let case = |(_, _, s, steps): &(f64, f64, ValidScene, usize)| {
            let c = Stewart::from_scene(s).map(|st| st.compensation().cloned().expect("has [control]"));
            let c = match c {
                Ok(c) => c,
                Err(e) => return Verdict::stopped(e.to_string()),
            };
            match history(s, &c, case_step(s), *steps, None) {
                Ok(r) => Verdict::judge(&r, &off_run),
                Err(e) => Verdict::stopped(format!("{e:#}")),
            }
        };
        let codec = Codec {
            key: |(rate, delay, ..): &(f64, f64, ValidScene, usize)| format!("{rate:?} Hz, delay {delay:?} s"),
            encode: Verdict::to_cells,
            decode: |_: &(f64, f64, ValidScene, usize), cells: &[String]| Verdict::from_cells(cells),
        };
        let verdicts = crate::points::map(&self.cases, jobs, |c| c.3 as f64, store, codec, |_, c| Ok(case(c)))?;

        let total = rms_peak(&on_run.feed_mm).0;
        let decoupled = rms_peak(&off_run.replayed_mm).0;
        // NaN when the run without the term stopped
        let share = |without: f64| {
            if without.is_nan() { f64::NAN } else { (total * total - without * without).max(0.0).sqrt() }
        };
        let line = |run, rms, term, value| BudgetLine { run, rms, term, value };
        let budget = vec![
            line("as the scene", total, "total", total),
            line("without the instrument's noise", budget_rms[0], "noise: √(total² − this²)", share(budget_rms[0])),
            line("without the delay", budget_rms[1], "delay: √(total² − this²)", share(budget_rms[1])),
            line("perfect instrument (neither)", budget_rms[2], "filter lag and sampling: this", budget_rms[2]),
            line("decoupled prediction", decoupled, "coupling: total − this", total - decoupled),
        ];
        Ok(Results {
            scene: scene.name.clone(),
            settings: self.settings.clone(),
            h,
            sample_interval_s: scene.outputs.sample_interval_s,
            off: off_run,
            on: on_run,
            cases: self.cases.iter().map(|c| (c.0, c.1)).collect(),
            verdicts,
            budget,
            budget_failures,
        })
    }
}

impl Results {
    /// `compensation.csv`: the cabin and the feed error of each long run, at the scene's sample
    /// interval.
    pub fn csv(&self) -> String {
        let (on, off) = (&self.on, &self.off);
        let every = ((self.sample_interval_s / self.h).round() as usize).max(1);
        let mut csv =
            String::from("t,cabin_disp_mm,feed_err_uncompensated_mm,feed_err_compensated_mm,feed_err_decoupled_mm\n");
        for i in (0..off.t.len()).step_by(every) {
            csv.push_str(&format!(
                "{},{:e},{:e},{:e},{:e}\n",
                on.t[i], on.cabin_mm[i], off.feed_mm[i], on.feed_mm[i], off.replayed_mm[i]
            ));
        }
        csv
    }

    /// `compensation.svg`: the cabin's motion and the feed's error.
    pub fn svg(&self) -> Result<String, PlotError> {
        let (on, off) = (&self.on, &self.off);
        let panels = [
            Panel {
                y_label: "|cabin displacement| (mm)".into(),
                legend: true,
                lines: vec![
                    Line { name: "compensated (coupled)", t: &on.t, y: on.cabin_mm.clone() },
                    Line { name: "uncompensated", t: &off.t, y: off.cabin_mm.clone() },
                ],
            },
            Panel {
                y_label: "|feed error| (mm)".into(),
                legend: true,
                lines: vec![
                    Line { name: "compensated (coupled)", t: &on.t, y: on.feed_mm.clone() },
                    Line { name: "uncompensated", t: &off.t, y: off.feed_mm.clone() },
                    Line { name: "compensated, decoupled prediction", t: &off.t, y: off.replayed_mm.clone() },
                ],
            },
        ];
        stacked(
            &format!("{}: the cabin's motion and the feed's error (monolithic model, h = {} s)", self.scene, self.h),
            &panels,
            300,
        )
    }

    /// `sweep.csv`: a line per case.
    pub fn sweep_csv(&self) -> String {
        let mut csv = String::from("sample_rate_hz,delay_s,verdict,feed_err_rms_mm,feed_err_peak_mm,note\n");
        for ((rate, delay), v) in self.cases.iter().zip(&self.verdicts) {
            let verdict = if v.stable { "stable" } else { "unstable" };
            csv.push_str(&format!(
                "{rate},{delay},{verdict},{:e},{:e},\"{}\"\n",
                v.rms,
                v.peak,
                v.note.replace('"', "'")
            ));
        }
        csv
    }

    /// `sweep.svg`: the feed error against the delay, a line per rate.
    pub fn sweep_svg(&self) -> Result<String, Box<dyn std::error::Error + Send + Sync>> {
        sweep_figure(&self.scene, &self.settings, &self.cases, &self.verdicts)
    }

    /// `budget.csv`.
    pub fn budget_csv(&self) -> String {
        let mut csv = String::from("run,feed_err_rms_mm,term,term_mm\n");
        for b in &self.budget {
            csv.push_str(&format!("{},{:e},{},{:e}\n", b.run, b.rms, b.term, b.value));
        }
        csv
    }

    /// The report as text: the long runs, the sweep, the budget.
    pub fn text(&self) -> String {
        let (on, off) = (&self.on, &self.off);
        let figures = |x: &[f64]| {
            let (rms, peak) = rms_peak(x);
            [format!("{rms:.3}"), format!("{peak:.3}")]
        };
        let mut table =
            Table::new(["run".to_string(), "feed error RMS (mm)".into(), "peak (mm)".into(), "cabin peak (mm)".into()]);
        let cabin_peak = |x: &[f64]| format!("{:.3}", rms_peak(x).1);
        let [a, b] = figures(&off.feed_mm);
        table.row(vec!["uncompensated".into(), a, b, cabin_peak(&off.cabin_mm)]);
        let [a, b] = figures(&on.feed_mm);
        table.row(vec!["compensated (coupled)".into(), a, b, cabin_peak(&on.cabin_mm)]);
        let [a, b] = figures(&off.replayed_mm);
        table.row(vec!["compensated, decoupled prediction".into(), a, b, cabin_peak(&off.cabin_mm)]);
        let s = &self.settings;
        let mut text =
            format!("{}: {} s, monolithic model, h = {} s (every step counted)\n", self.scene, s.t_end, self.h);
        text.push_str(&table.render());
        let mut sweep = Table::new(
            std::iter::once("rate \\ delay".to_string()).chain(s.delays.iter().map(|d| format!("{} ms", d * 1e3))),
        );
        for &rate in &s.rates {
            let mut row = vec![format!("{rate} Hz")];
            for &delay in &s.delays {
                let i = self.cases.iter().position(|c| c.0 == rate && c.1 == delay).expect("every case ran");
                let v = &self.verdicts[i];
                row.push(if v.stable { format!("{:.3}", v.rms) } else { "unstable".into() });
            }
            sweep.row(row);
        }
        text.push_str(&format!("\nfeed error RMS (mm) over {} s against sensor rate and delay:\n", s.sweep_t_end));
        text.push_str(&sweep.render());
        let mut terms = Table::new(["run", "feed error RMS (mm)", "term", "term (mm)"]);
        for b in &self.budget {
            terms.row(vec![b.run.to_string(), format!("{:.3}", b.rms), b.term.to_string(), format!("{:.3}", b.value)]);
        }
        text.push_str(&format!("\nerror budget over {} s:\n", s.t_end));
        text.push_str(&terms.render());
        text
    }
}

/// Feed error RMS against delay, a line per sample rate; unstable cases as crosses on the top.
fn sweep_figure(
    name: &str,
    settings: &Settings,
    cases: &[(f64, f64)],
    results: &[Verdict],
) -> Result<String, Box<dyn std::error::Error + Send + Sync>> {
    let stable_max = results.iter().filter(|v| v.stable).map(|v| v.rms).fold(0.0, f64::max);
    let top = if stable_max > 0.0 { stable_max * 1.25 } else { 1.0 };
    let x_max = settings.delays.iter().copied().fold(0.0, f64::max).max(1e-3) * 1e3 * 1.05;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 520)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{name}: feed error RMS over {} s against sensor delay (× unstable)", settings.sweep_t_end),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..x_max, 0.0..top * 1.1)?;
        chart
            .configure_mesh()
            .x_desc("sensor delay (ms)")
            .y_desc("feed error RMS (mm)")
            .label_style(("sans-serif", 13))
            .draw()?;
        for (k, &rate) in settings.rates.iter().enumerate() {
            let color = PALETTE[k % PALETTE.len()];
            let points: Vec<(f64, f64, bool)> = cases
                .iter()
                .zip(results)
                .filter(|(c, _)| c.0 == rate)
                .map(|(c, v)| (c.1 * 1e3, v.rms, v.stable))
                .collect();
            let stable: Vec<(f64, f64)> = points.iter().filter(|p| p.2).map(|p| (p.0, p.1)).collect();
            chart
                .draw_series(LineSeries::new(stable.clone(), color.stroke_width(2)))?
                .label(format!("{rate} Hz"))
                .legend(crate::plot::line_key(color.stroke_width(2)));
            chart.draw_series(stable.iter().map(|&p| Circle::new(p, 4, color.filled())))?;
            chart.draw_series(
                points.iter().filter(|p| !p.2).map(|p| Cross::new((p.0, top), 6, color.stroke_width(2))),
            )?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}

/// A run of the error budget: the scene with part of its instrument made perfect.
#[derive(Clone, Copy, Debug)]
pub enum Budget {
    /// No noise on the sampled sensor; the inertial unit without noise, bias or walk; the
    /// fusion filter's noise model as it was (`[control.imu.filter]` written out).
    Noiseless,
    /// No delay.
    Prompt,
    /// Neither noise nor delay.
    Perfect,
}

impl Budget {
    pub fn label(&self) -> &'static str {
        match self {
            Budget::Noiseless => "without noise",
            Budget::Prompt => "without delay",
            Budget::Perfect => "with a perfect instrument",
        }
    }

    pub fn apply(&self, s: &mut Scene) {
        let Some(c) = s.control.as_mut() else { return };
        if matches!(self, Budget::Noiseless | Budget::Perfect) {
            // the filter keeps its noise model: only the instruments lose their noise
            let model = c.fusion_model();
            (c.noise_m, c.noise_rad) = (0.0, 0.0);
            if let Some(imu) = c.imu.as_mut() {
                imu.filter = model.map(|m| m.as_filter());
                (imu.accel_noise_density, imu.gyro_noise_density) = (0.0, 0.0);
                (imu.accel_bias_m_s2, imu.gyro_bias_rad_s) = ([0.0; 3], [0.0; 3]);
                (imu.accel_bias_walk, imu.gyro_bias_walk) = (0.0, 0.0);
            }
        }
        if matches!(self, Budget::Prompt | Budget::Perfect) {
            c.delay_s = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The budget's instrument without noise keeps the filter that expects the noise: only the
    /// readings change, so the difference is the noise's share.
    #[test]
    fn a_noiseless_instrument_keeps_its_filters_noise_model() {
        let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/lt50m_C_total_station.toml");
        let scene = feedcore::scene::Scene::load(file).unwrap().to_scene();
        let before = scene.control.as_ref().unwrap().fusion_model().unwrap();
        assert!(before.accel_noise_density > 0.0 && before.fix_noise_m > 0.0);
        for budget in [Budget::Noiseless, Budget::Perfect] {
            let mut s = scene.clone();
            budget.apply(&mut s);
            let c = s.control.as_ref().unwrap();
            let imu = c.imu.as_ref().unwrap();
            assert_eq!((c.noise_m, c.noise_rad, imu.accel_noise_density, imu.gyro_noise_density), (0.0, 0.0, 0.0, 0.0));
            assert_eq!(c.fusion_model(), Some(before), "{}", budget.label());
        }
    }

    /// A journal case reads back as written, NaN for a stopped run included; an error that is
    /// not finite, negative, missing from a stable case, or a case of another shape does not.
    #[test]
    fn only_a_case_a_run_can_give_reads_back_from_the_journal() {
        let stable = Verdict { stable: true, rms: 3.45, peak: 9.1, note: String::new() };
        let stopped = Verdict::stopped("a leg left its range".into());
        for v in [&stable, &stopped] {
            let back = Verdict::from_cells(&v.to_cells()).unwrap();
            assert_eq!(back.to_cells(), v.to_cells());
        }
        let cells = |x: [&str; 4]| x.map(String::from);
        for bad in [
            cells(["true", "NaN", "NaN", ""]),
            cells(["true", "inf", "9.1", ""]),
            cells(["false", "-1", "9.1", ""]),
            cells(["yes", "3.45", "9.1", ""]),
        ] {
            assert!(Verdict::from_cells(&bad).is_err(), "{bad:?}");
        }
        assert!(Verdict::from_cells(&stable.to_cells()[..3]).is_err());
    }
}
