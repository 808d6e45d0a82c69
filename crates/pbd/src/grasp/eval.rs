//! `pbd grasp eval`: the experiment of §6.5. Catalog presentations are split at random (seeded)
//! into training and test sets; the scripted teacher demonstrates grasps on the training set in the
//! sim, the prototype model is learned from them; every test presentation is presented and seen,
//! and 6 candidates from the model and 6 from the naive baseline (after the same collision and
//! reach filtering) are each executed in the sim: reach the pre-grasp, close, lift 10 cm, success if
//! still held. Reported: success per object (Fig. 6.7), totals, a significance test and the object ×
//! prototype sharing table (Table 6.1).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use dexter_sim::grasp_trial::{self, Percept, TrialOutcome};
use grasp_topics::{Corpus, GraspModel, naive_baseline};
use rand::seq::SliceRandom;
use serde::{Deserialize, Serialize};

use super::common::{self, Method, Presenter, Rejections, select_candidates};
use super::report::{EvalSummary, ObjectResult, Trial};
use super::{PresentOptions, command_for, learn_config, mat2, model_summary, record_scripted};
use crate::mcap_log::PreGraspMarker;
use crate::progress::Progress;

/// Options of [`run`] (`pbd grasp eval`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalOptions {
    /// Where and how objects are presented.
    pub present: PresentOptions,
    /// Number of test presentations (the seed used 12).
    pub test: usize,
    /// Number of training presentations (the seed used 19); 0 = all the others.
    pub train: usize,
    /// Test presentations (default: drawn at random).
    pub objects: Vec<String>,
    /// Demonstrations attempted per training presentation.
    pub demos: usize,
    /// Candidates executed per test presentation and method (the seed used 6).
    pub candidates: usize,
    /// Use this model instead of recording and learning (test presentations exclude its objects).
    pub model: Option<PathBuf>,
    /// Learn from this corpus instead of recording one (test presentations exclude its objects).
    pub corpus: Option<PathBuf>,
    /// Number of prototypes A (the seed used 10).
    pub prototypes: usize,
    /// Infer the number of prototypes (Dirichlet process).
    pub nonparametric: bool,
    /// Number of canonical orientations Q (the seed used 6).
    pub orientations: usize,
    /// Burn-in sweeps of the sampler.
    pub burn_in: usize,
    /// Sampler chains.
    pub chains: usize,
    /// Seed of every random choice (split, demonstrations, sampler, candidates, sim noise).
    pub seed: u64,
    /// Split by object, not by presentation: no presentation of a test presentation's object is
    /// trained on (`jif-2` is not learned from when `jif-1` is tested), and with a given model or
    /// corpus no presentation of its objects is tested.
    pub object_split: bool,
    /// Filter the naive baseline's candidates against the object as the model's are (by default,
    /// as in the seed, they are filtered only against the table: its hemisphere puts the open
    /// fingers into the object).
    pub naive_filtered: bool,
    /// Directory for the report (trials.csv, objects.csv, sharing.csv, summary.md, summary.json;
    /// corpus.json and prototypes.json when learned here; the figure fig6_7.svg is the caller's).
    pub output: PathBuf,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            present: PresentOptions::default(),
            test: 12,
            train: 24,
            objects: Vec::new(),
            demos: 4,
            candidates: 6,
            model: None,
            corpus: None,
            prototypes: 10,
            nonparametric: false,
            orientations: 6,
            burn_in: 200,
            chains: 4,
            seed: 0,
            object_split: false,
            naive_filtered: false,
            output: PathBuf::from("grasp-eval"),
        }
    }
}

struct Prepared {
    percept: Option<Percept>,
    top_prototype: Option<usize>,
    jobs: Vec<(Method, usize, Option<grasp_topics::RankedPreGrasp>)>,
    rejected: [Rejections; 2],
}

/// The fixed files `grasp eval` writes in its output directory (besides `candidates/`).
pub const OUTPUT_FILES: &[&str] = &[
    "corpus.json",
    "prototypes.json",
    "summary.json",
    "summary.md",
    "fig6_7.svg",
    "trials.csv",
    "objects.csv",
    "sharing.csv",
];

/// `pbd grasp eval`: the §6.5 experiment. Writes the report files into `output` and returns the
/// summary; [`super::report::figure`] gives Fig. 6.7 to draw. The same seed gives the same files on
/// any number of threads.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn run(args: &EvalOptions, progress: &dyn Progress) -> crate::Result<EvalSummary> {
    run_impl(args, progress).map_err(crate::Error::from)
}

fn run_impl(args: &EvalOptions, progress: &dyn Progress) -> anyhow::Result<EvalSummary> {
    let wall = Instant::now();
    // Config.
    let presenter = Presenter::new(&args.present)?;
    if args.candidates == 0 {
        bail!("candidates must be at least 1");
    }
    for (name, v) in [
        ("candidates", args.candidates),
        ("test", args.test),
        ("train", args.train),
        ("demos", args.demos),
    ] {
        crate::limits::check_at_most(name, v, crate::limits::MAX_PER_OBJECT)?;
    }
    for o in &args.objects {
        presenter.check(o)?;
    }
    let config = learn_config(
        args.prototypes,
        args.nonparametric,
        1.0,
        args.orientations,
        args.burn_in,
        args.chains,
        args.seed,
    );
    config.validate()?;
    let given_model = args.model.as_ref().map(GraspModel::load).transpose()?;
    let mut io = crate::files::IoPlan::new();
    if let Some(c) = &args.corpus {
        io.read("--corpus", c);
    }
    io.write_in("-o", &args.output, OUTPUT_FILES).check()?;
    let given_corpus = args.corpus.as_ref().map(Corpus::load).transpose()?;
    if let Some(c) = &given_corpus {
        c.validate()?;
    }
    std::fs::create_dir_all(&args.output).with_context(|| format!("cannot create {}", args.output.display()))?;
    // Split.
    let all = shuffled_presentations(&presenter, args.seed);
    let known: Vec<String> = match (&given_model, &given_corpus) {
        (Some(m), _) => m.objects.clone(),
        (_, Some(c)) => c.objects.iter().map(|o| o.name.clone()).collect(),
        _ => Vec::new(),
    };
    let test = test_split(&presenter, &all, &known, args);
    if test.is_empty() {
        bail!("no test presentations (every catalog presentation is a training object of the model)");
    }
    let mut files = Vec::new();
    let path_str = |p: &std::path::Path| p.display().to_string();
    // Model.
    let mut demos_kept = None;
    let model = if let Some(m) = given_model {
        m
    } else {
        let corpus = match given_corpus {
            Some(c) => c,
            None => {
                let pool = training_pool(&presenter, &all, &test, args.object_split);
                let n = if args.train == 0 {
                    pool.len()
                } else {
                    args.train.min(pool.len())
                };
                let train = &pool[..n];
                if train.is_empty() {
                    bail!("no training presentations left after the test split");
                }
                progress.phase("demonstrate", Some(train.len() as u64));
                let (corpus, demos, _skipped) = record_scripted(&presenter, train, args.demos, args.seed, progress)?;
                progress.finish();
                demos_kept = Some((demos.iter().filter(|d| d.kept).count(), demos.len()));
                if corpus.num_grasps() == 0 {
                    bail!("no demonstrated grasp held on the training presentations");
                }
                let p = args.output.join("corpus.json");
                crate::files::write_atomic(&p, corpus.to_json_string()?.as_bytes())?;
                files.push(path_str(&p));
                corpus
            }
        };
        progress.phase("learn", None);
        let m = GraspModel::learn(&corpus, &config)?;
        progress.finish();
        let p = args.output.join("prototypes.json");
        crate::files::write_atomic(&p, m.to_json_string()?.as_bytes())?;
        files.push(path_str(&p));
        m
    };
    let model_path = args
        .model
        .clone()
        .unwrap_or_else(|| args.output.join("prototypes.json"));
    // Perceive each test object and choose its candidates.
    let n = args.candidates;
    progress.phase("perceive", Some(test.len() as u64));
    let indexed: Vec<(usize, &String)> = test.iter().enumerate().collect();
    let prepared = crate::parallel::map(&indexed, progress, |&(i, name)| {
        prepare(&presenter, &model, args, n, i, name)
    })?;
    progress.finish();
    // Execute every candidate.
    let mut jobs = Vec::new();
    for (i, p) in prepared.iter().enumerate() {
        for (m, k, c) in &p.jobs {
            jobs.push((i, *m, *k, c.clone()));
        }
    }
    progress.phase("grasp", Some(jobs.len() as u64));
    // On Ctrl-C, candidates not yet started are skipped: the objects whose every candidate ran are
    // written, marked partial.
    let outcomes = crate::parallel::map_until_stopped(&jobs, progress, |(i, m, _k, c)| {
        execute_job(&presenter, args.seed, &test[*i], *i, &prepared[*i], *m, c.as_ref())
    })?;
    progress.finish();
    let complete: Vec<bool> = (0..test.len())
        .map(|i| jobs.iter().zip(&outcomes).all(|(j, o)| j.0 != i || o.is_some()))
        .collect();
    let trials: Vec<Trial> = jobs
        .iter()
        .zip(outcomes)
        .filter(|((i, ..), _)| complete[*i])
        .filter_map(|((i, m, k, c), o)| {
            Some(to_trial(
                &test[*i],
                prepared[*i].percept.is_some(),
                *m,
                *k,
                c.as_ref(),
                o?,
            ))
        })
        .collect();
    // Each finished test object's candidates drawn for Foxglove, coloured by outcome.
    for (i, name) in test.iter().enumerate().filter(|(i, _)| complete[*i]) {
        let markers: Vec<PreGraspMarker> = prepared[i]
            .jobs
            .iter()
            .filter_map(|(m, k, c)| {
                let c = c.as_ref()?;
                let t = trials
                    .iter()
                    .find(|t| t.object == *name && t.method == *m && t.candidate == k + 1);
                Some(PreGraspMarker {
                    rank: k + 1,
                    world_from_palm: c.world_from_palm,
                    label: format!(
                        "{} #{}{}",
                        m.name(),
                        k + 1,
                        t.map_or("", |t| if t.success { " held" } else { " missed" })
                    ),
                    group: m.name().into(),
                    held: t.map(|t| t.success),
                })
            })
            .collect();
        if markers.is_empty() {
            continue;
        }
        let (scene, settings) = presenter.scene(name, crate::rng::split(args.seed, 1000 + i as u64))?;
        let sim = grasp_trial::parked_sim(&scene, &settings)?;
        let dir = args.output.join("candidates");
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let safe: String = name
            .chars()
            .map(|ch| {
                if ch.is_ascii_alphanumeric() || "-_.".contains(ch) {
                    ch
                } else {
                    '_'
                }
            })
            .collect();
        let p = dir.join(format!("{safe}.mcap"));
        super::draw_pre_grasps(&p, &scene, &sim, &markers).with_context(|| format!("writing {}", p.display()))?;
        files.push(path_str(&p));
    }
    let done = complete.iter().filter(|c| **c).count();
    let partial = (done < test.len()).then(|| format!("interrupted after {done} of {} test objects", test.len()));
    let objects: Vec<ObjectResult> = test
        .iter()
        .enumerate()
        .filter(|(i, _)| complete[*i])
        .map(|(i, name)| object_result(name, &prepared[i], &trials))
        .collect();
    if done == 0 && partial.is_some() {
        bail!("interrupted before any test object finished: nothing to write");
    }
    let attempts = done * n;
    let ms: usize = objects.iter().map(|o| o.model).sum();
    let ns: usize = objects.iter().map(|o| o.naive).sum();
    let significance = super::report::significance(ms, ns, attempts)?;
    let summary_model = model_summary(&model, &model_path);
    let mut summary = EvalSummary {
        seed: args.seed,
        object_split: args.object_split,
        naive_filtered: args.naive_filtered,
        train: model.objects.clone(),
        test: test.clone(),
        candidates: n,
        demos_kept,
        model: summary_model,
        objects,
        model_total: (ms, attempts),
        naive_total: (ns, attempts),
        significance,
        wall_time: 0.0,
        files,
        partial: partial.clone(),
    };
    summary.wall_time = wall.elapsed().as_secs_f64();
    super::report::write_files(&args.output, &mut summary, &trials, &model)?;
    let p = args.output.join("summary.json");
    crate::files::write_atomic(&p, serde_json::to_string_pretty(&summary)?.as_bytes())?;
    summary.files.push(path_str(&p));
    if let Some(why) = partial {
        bail!(
            "{why}; the partial results are in {} (marked PARTIAL)",
            args.output.display()
        );
    }
    Ok(summary)
}

/// Perceives test presentation `i` (`name`) and chooses its candidates for both methods.
fn prepare(
    presenter: &Presenter,
    model: &GraspModel,
    args: &EvalOptions,
    n: usize,
    i: usize,
    name: &str,
) -> Result<Prepared> {
    let seed = args.seed;
    let (scene, settings) = presenter.scene(name, crate::rng::split(seed, 1000 + i as u64))?;
    let percept = match grasp_trial::perceive(&scene, &settings)? {
        Ok(p) => p,
        Err(_) => {
            let mut jobs = Vec::new();
            for m in [Method::Model, Method::Naive] {
                for k in 0..n {
                    jobs.push((m, k, None));
                }
            }
            return Ok(Prepared {
                percept: None,
                top_prototype: None,
                jobs,
                rejected: [Rejections::default(); 2],
            });
        }
    };
    let reach_sim = grasp_trial::parked_sim(&scene, &settings)?;
    let b = mat2(percept.appearance);
    let pz = model.prototype_probabilities(&b)?;
    let top = pz.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map(|(j, _)| j);
    let dims = common::seen_shape(&percept).0.dimensions();
    let mut jobs = Vec::new();
    let mut rejected = [Rejections::default(); 2];
    for (mi, m) in [Method::Model, Method::Naive].into_iter().enumerate() {
        let mut rng = crate::rng::stream(seed, 2000 + 2 * i as u64 + mi as u64);
        let sel = select_candidates(
            presenter,
            &scene,
            &reach_sim,
            &percept,
            m,
            n,
            args.naive_filtered,
            |k, rng| match m {
                Method::Model => model.generate(&b, k, rng).map_err(anyhow::Error::from),
                Method::Naive => naive_baseline(&dims, k, rng).map_err(anyhow::Error::from),
            },
            &mut rng,
        )?;
        rejected[mi] = sel.rejected;
        for k in 0..n {
            jobs.push((m, k, sel.chosen.get(k).cloned()));
        }
    }
    Ok(Prepared {
        percept: Some(percept),
        top_prototype: top,
        jobs,
        rejected,
    })
}

/// Executes one candidate (`None`: nothing to execute) of test presentation `i`.
fn execute_job(
    presenter: &Presenter,
    seed: u64,
    name: &str,
    i: usize,
    prepared: &Prepared,
    m: Method,
    c: Option<&grasp_topics::RankedPreGrasp>,
) -> Result<Option<TrialOutcome>> {
    let Some(c) = c else { return Ok(None) };
    let (scene, settings) = presenter.scene(name, crate::rng::split(seed, 1000 + i as u64))?;
    let seen = prepared.percept.as_ref().context("a candidate without a percept")?;
    Ok(Some(grasp_trial::execute(
        &scene,
        &settings,
        presenter.arm,
        &command_for(c, m),
        seen,
    )?))
}

/// The report row of one executed (or not executable) candidate.
fn to_trial(
    object: &str,
    seen: bool,
    m: Method,
    k: usize,
    c: Option<&grasp_topics::RankedPreGrasp>,
    o: Option<TrialOutcome>,
) -> Trial {
    Trial {
        object: object.to_string(),
        method: m,
        candidate: k + 1,
        prototype: c.and_then(|c| c.pre_grasp.prototype.map(|j| j + 1)),
        position: c.map(|c| c.pre_grasp.position),
        orientation: c.map(|c| c.pre_grasp.orientation),
        success: o.as_ref().is_some_and(|o| o.success),
        rose: o.as_ref().map_or(0.0, |o| o.rose),
        outcome: match (&o, seen) {
            (Some(o), _) => o.outcome.clone(),
            (None, false) => "object not seen".into(),
            (None, true) => "no collision-free reachable candidate".into(),
        },
        sim_time: o.as_ref().map_or(0.0, |o| o.sim_time),
    }
}

/// The object's row of the report from its trials.
fn object_result(name: &str, prepared: &Prepared, trials: &[Trial]) -> ObjectResult {
    let count = |m: Method| {
        trials
            .iter()
            .filter(|t| t.object == name && t.method == m && t.success)
            .count()
    };
    ObjectResult {
        object: name.to_string(),
        model: count(Method::Model),
        naive: count(Method::Naive),
        appearance: prepared.percept.as_ref().map(|p| p.appearance),
        top_prototype: prepared.top_prototype.map(|j| j + 1),
        model_rejected: prepared.rejected[0],
        naive_rejected: prepared.rejected[1],
    }
}

/// The catalog presentations in the experiment's seeded order (the test split takes them in this order).
fn shuffled_presentations(presenter: &Presenter, seed: u64) -> Vec<String> {
    let mut all = presenter.presentations();
    all.shuffle(&mut crate::rng::stream(seed, 1));
    all
}

/// The test presentations [`run`] uses with a model trained on `known` objects (`args.objects`, or the
/// first `args.test` catalog presentations in the seed's order that are not in `known`): the objects
/// of [`object_trial`] by index.
pub fn test_presentations(args: &EvalOptions, known: &[String]) -> Result<Vec<String>> {
    let presenter = Presenter::new(&args.present)?;
    Ok(test_split(
        &presenter,
        &shuffled_presentations(&presenter, args.seed),
        known,
        args,
    ))
}

/// The presentations of `all` that may be trained on: not tested, and with `object_split` no
/// presentation of a tested object.
fn training_pool(presenter: &Presenter, all: &[String], test: &[String], object_split: bool) -> Vec<String> {
    let tested: Vec<String> = test.iter().filter_map(|t| presenter.object_of(t)).collect();
    all.iter()
        .filter(|o| !test.contains(o))
        .filter(|o| !object_split || presenter.object_of(o).is_none_or(|ob| !tested.contains(&ob)))
        .cloned()
        .collect()
}

/// [`test_presentations`] from the shuffled list.
fn test_split(presenter: &Presenter, all: &[String], known: &[String], args: &EvalOptions) -> Vec<String> {
    let known_objects: Vec<String> = known.iter().filter_map(|k| presenter.object_of(k)).collect();
    if args.objects.is_empty() {
        all.iter()
            .filter(|o| !known.contains(o))
            .filter(|o| !args.object_split || presenter.object_of(o).is_none_or(|ob| !known_objects.contains(&ob)))
            .take(args.test)
            .cloned()
            .collect()
    } else {
        args.objects.clone()
    }
}

/// One test presentation of the experiment: the object's report row and its trials.
#[derive(Debug, Clone, Serialize)]
pub struct ObjectTrial {
    /// Successes per method, appearance, top prototype, rejected candidates.
    pub object: ObjectResult,
    /// Every candidate of both methods, executed in the sim.
    pub trials: Vec<Trial>,
}

/// Test presentation `index` (`object`) of the §6.5 experiment with a given prototype model, as a
/// pure function of its arguments: perceive it, choose `args.candidates` candidates from the model
/// and from the naive baseline, execute them. Gives exactly the rows [`run`] gives for the object at
/// position `index` of its test list (same `args.present`, `args.seed` and `args.candidates`), so
/// the experiment can be spread over any scheduler one object at a time.
pub fn object_trial(args: &EvalOptions, model: &GraspModel, index: usize, object: &str) -> Result<ObjectTrial> {
    let presenter = Presenter::new(&args.present)?;
    presenter.check(object)?;
    if args.candidates == 0 {
        bail!("candidates must be at least 1");
    }
    let prepared = prepare(&presenter, model, args, args.candidates, index, object)?;
    let mut trials = Vec::new();
    for (m, k, c) in &prepared.jobs {
        let o = execute_job(&presenter, args.seed, object, index, &prepared, *m, c.as_ref())?;
        trials.push(to_trial(object, prepared.percept.is_some(), *m, *k, c.as_ref(), o));
    }
    Ok(ObjectTrial {
        object: object_result(object, &prepared, &trials),
        trials,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An object split keeps every presentation of a tested object out of training, and every
    /// presentation of a known object out of the test set; a presentation split only the
    /// presentation itself.
    #[test]
    fn an_object_split_keeps_every_presentation_of_a_tested_object_out_of_training() {
        let presenter = Presenter::new(&PresentOptions::default()).unwrap();
        let all = shuffled_presentations(&presenter, 0);
        let of = |p: &str| presenter.object_of(p).unwrap();
        // An object with several presentations.
        let multi = all
            .iter()
            .find(|p| all.iter().filter(|q| of(q) == of(p)).count() >= 2)
            .expect("a catalog object with two presentations")
            .clone();
        let siblings: Vec<&String> = all.iter().filter(|q| of(q) == of(&multi) && **q != multi).collect();
        let test = vec![multi.clone()];
        let by_presentation = training_pool(&presenter, &all, &test, false);
        assert!(!by_presentation.contains(&multi));
        assert!(siblings.iter().all(|s| by_presentation.contains(s)));
        let by_object = training_pool(&presenter, &all, &test, true);
        assert!(by_object.iter().all(|p| of(p) != of(&multi)), "{by_object:?}");
        assert_eq!(by_object.len(), all.len() - 1 - siblings.len());
        // A model that knows `multi`: an object split tests none of its siblings.
        let mut args = EvalOptions {
            test: all.len(),
            ..EvalOptions::default()
        };
        let tested = test_split(&presenter, &all, &test, &args);
        assert!(siblings.iter().all(|s| tested.contains(s)));
        args.object_split = true;
        let tested = test_split(&presenter, &all, &test, &args);
        assert!(tested.iter().all(|p| of(p) != of(&multi)), "{tested:?}");
    }
}
