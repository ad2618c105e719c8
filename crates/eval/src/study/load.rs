//! Loading a study: its file parsed and checked, the files it names loaded
//! (scenarios, models, profiles), every problem reported at once under its
//! field, and the sweep grid's points built.

use super::Study;
use super::check::{
    channel_rate_axis, check_methods, load_each, missing_axis, runs_problem, sample_rates,
    scale_axis, settings_axis, study_profiles, turbulence_axis,
};
use super::file::StudyFile;
use super::points::Grid;
use crate::error::Result;
use aeroid_core::catalog;
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_estimation::registry::Registry;
use aeroid_estimation::structure::Structure;
use aeroid_record::recorder::Profile;
use aeroid_sim::scenario::Scenario;
use std::path::Path;

/// The values of the axes that need no profile, checked.
struct PlainAxes {
    sample_rates: Vec<Option<f64>>,
    noise_scales: Vec<f64>,
    resolution_scales: Vec<f64>,
    input_scales: Vec<f64>,
    turbulence: Vec<Option<String>>,
}

impl Study {
    /// Loads a study by bundled name (`studies/NAME.toml`) or path.
    pub fn load(registry: &Registry, reference: &str) -> Result<Study> {
        let path = catalog::resolve(reference, catalog::STUDY_FOLDER, None)?;
        let file: StudyFile = parse_toml(&path, &read_text(&path)?)?;
        Study::from_file(registry, &file, &path)
    }

    /// Validates a parsed study and loads the files it names, reporting every
    /// problem at once under its field.
    pub fn from_file(registry: &Registry, file: &StudyFile, path: &Path) -> Result<Study> {
        let base = path.parent().unwrap_or(Path::new("."));
        let mut problems = FieldErrors::default();
        if file.name.trim().is_empty() {
            problems.push("name", "must not be empty");
        }
        let (scenarios, models) = load_files(registry, file, base, &mut problems);
        let profiles = study_profiles(file, base, &mut problems);
        check_methods(&file.methods, registry, &mut problems);
        registry.check_tables(&file.methods.tables(), &mut problems);
        if let Some(message) = runs_problem(file.runs) {
            problems.push("runs", message);
        }
        let plain = plain_axes(file, &mut problems);
        let invalid = |problems: FieldErrors| aeroid_core::Error::Invalid {
            path: path.to_path_buf(),
            problems: problems.0,
        };
        let Some(profiles) = profiles else {
            return Err(invalid(problems).into());
        };
        check_derive(file, &profiles, &mut problems);
        let sweep = &file.sweep;
        let missing = missing_axis(&sweep.missing, &profiles, &mut problems);
        let channel_rates = channel_rate_axis(&sweep.channel_rate, &profiles, &mut problems);
        let variants = settings_axis(&sweep.settings, registry, &mut problems);
        if !problems.is_empty() {
            return Err(invalid(problems).into());
        }
        let points = Grid {
            scenarios: scenarios.len(),
            profiles: &profiles,
            missing,
            channel_rates,
            turbulence: plain.turbulence,
            input_scales: plain.input_scales,
            sample_rates: plain.sample_rates,
            noise_scales: plain.noise_scales,
            resolution_scales: plain.resolution_scales,
            settings: &variants,
        }
        .points()?;
        let study = Study {
            name: file.name.clone(),
            description: file.description.clone(),
            path: path.to_path_buf(),
            scenarios,
            profiles,
            models,
            methods: file.methods.names(registry),
            settings: file.methods.tables(),
            setting_variants: variants,
            runs: file.runs,
            seed: file.seed,
            points,
            derive: file.derive.clone(),
            registry: registry.clone(),
        };
        study.check_size("runs")?;
        Ok(study)
    }
}

/// The study's scenarios (their settings checked) and models.
fn load_files(
    registry: &Registry,
    file: &StudyFile,
    base: &Path,
    problems: &mut FieldErrors,
) -> (Vec<Scenario>, Vec<Structure>) {
    let resolved = |reference: &str, folder: &str| {
        catalog::resolve(reference, folder, Some(base))
            .map(|path| path.to_string_lossy().into_owned())
    };
    let scenarios = load_each("scenarios", &file.scenarios, problems, |r| {
        let scenario = Scenario::load(&resolved(r, catalog::SCENARIO_FOLDER)?)?;
        registry.validate_tables(&scenario.methods, &scenario.path)?;
        Ok::<_, crate::Error>(scenario)
    });
    let models = load_each("models", &file.models, problems, |r| {
        Structure::load(&resolved(r, catalog::MODEL_FOLDER)?)
    });
    (scenarios, models)
}

/// The sample-rate, scale and turbulence axes, checked.
fn plain_axes(file: &StudyFile, problems: &mut FieldErrors) -> PlainAxes {
    let sweep = &file.sweep;
    let sample_rates = sample_rates(&sweep.sample_rate, problems);
    let noise_scales = scale_axis("noise_scale", &sweep.noise_scale, false, problems);
    let resolution_scales =
        scale_axis("resolution_scale", &sweep.resolution_scale, false, problems);
    let input_scales = scale_axis("input_scale", &sweep.input_scale, true, problems);
    let turbulence = turbulence_axis(&sweep.turbulence, problems);
    PlainAxes {
        sample_rates,
        noise_scales,
        resolution_scales,
        input_scales,
        turbulence,
    }
}

/// Every profile the derive step names is one of the study's.
fn check_derive(file: &StudyFile, profiles: &[Profile], problems: &mut FieldErrors) {
    for name in file.derive.iter().flat_map(|d| &d.profiles) {
        if !profiles.iter().any(|p| &p.name == name) {
            problems.push(
                "derive.profiles",
                format!(
                    "'{name}' is not one of the study's profiles ({})",
                    profiles
                        .iter()
                        .map(|p| p.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            );
        }
    }
}
