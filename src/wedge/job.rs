//! The wedge as an Open Job Description job (`jobtemplate-2023-09`): a `Bake` step whose
//! task parameter space is the variants, each task baking one variant shot into its own
//! folder, and a `Gather` step after it that makes the contact sheet. `openjd run` runs
//! it locally, AWS Deadline Cloud runs the same template from a job bundle (docs/farm.md).

/// A YAML double-quoted scalar: JSON string syntax is valid YAML.
fn q(s: &str) -> String {
    serde_json::to_string(s).expect("a string serialises")
}

/// What the template needs to know of a wedge.
pub struct JobSpec<'a> {
    /// The wedged shot's scene name; variant k's shot is `variants/<name>_<k>.toml`.
    pub name: &'a str,
    pub variants: usize,
    /// Default of the `WedgeDir` parameter: the wedge folder relative to the template's
    /// folder (OpenJD joins a relative default to it; an absolute one is refused).
    pub wedge_dir: &'a str,
    /// Default of the `Beeswarm` parameter: the program the tasks run.
    pub beeswarm: &'a str,
    /// Default of `CheckpointEvery`: frames between a bake's checkpoints (0: none).
    pub checkpoint_every: u32,
}

/// The job template, YAML.
pub fn template(spec: &JobSpec) -> String {
    let JobSpec {
        name,
        variants,
        wedge_dir,
        beeswarm,
        checkpoint_every,
    } = *spec;
    let variant_shot =
        format!("{{{{Param.WedgeDir}}}}/variants/{name}_{{{{Task.Param.Variant}}}}.toml");
    format!(
        r#"# Open Job Description job template written by `beeswarm wedge` (see docs/farm.md).
# Run it locally:      openjd run job.yaml
# On Deadline Cloud:   deadline bundle submit .   (this folder is the job bundle)
specificationVersion: jobtemplate-2023-09
name: {job_name}
description: {description}
parameterDefinitions:
- name: WedgeDir
  type: PATH
  objectType: DIRECTORY
  dataFlow: INOUT
  default: {wedge_dir}
  description: The wedge folder (variants/, caches/) that beeswarm wedge wrote.
- name: Beeswarm
  type: STRING
  minLength: 1
  default: {beeswarm}
  description: The beeswarm program the tasks run (a path, or a name on the worker's PATH).
- name: CheckpointEvery
  type: INT
  minValue: 0
  default: {checkpoint_every}
  description: Frames between a bake's checkpoints; a task run again resumes from the last one (0 = none).
steps:
- name: Bake
  description: Bakes one variant shot into caches/<variant>/.
  parameterSpace:
    taskParameterDefinitions:
    - name: Variant
      type: INT
      range: {range}
  script:
    actions:
      onRun:
        command: "{{{{Param.Beeswarm}}}}"
        args:
        - bake
        - {variant_shot}
        - --checkpoint-every
        - "{{{{Param.CheckpointEvery}}}}"
        - --resume
- name: Gather
  description: Puts every variant's preview in one labelled contact sheet.
  dependencies:
  - dependsOn: Bake
  script:
    actions:
      onRun:
        command: "{{{{Param.Beeswarm}}}}"
        args:
        - gather
        - "{{{{Param.WedgeDir}}}}"
"#,
        job_name = q(&format!("beeswarm wedge {name} ({variants} variants)")),
        description = q(&format!(
            "{variants} variants of the shot {name}, each baked by one task, then a contact sheet."
        )),
        wedge_dir = q(wedge_dir),
        beeswarm = q(beeswarm),
        checkpoint_every = checkpoint_every,
        range = q(&format!("1-{variants}")),
        variant_shot = q(&variant_shot),
    )
}
