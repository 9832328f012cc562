//! A session's records besides the estimation record: the time range
//! files, the experiments of a multi-record identification and the
//! validation record, each adopted from a folder or uploaded.

use std::path::PathBuf;

use lifted_lti::ModelFile;

use crate::error::{CliResult, input};
use crate::studio::ranges;

use super::*;

impl Session {
    /// The file of the rows of `range` of the record `src` (written once,
    /// [`ranges::slice_file`]), aligned to the frame of the request's
    /// outputs and hold; `what` names the range in errors.
    pub(super) fn range_file(
        &self,
        src: &Record,
        range: [f64; 2],
        r: &Request,
        what: &str,
    ) -> CliResult<(String, PathBuf)> {
        let ts = r.ts.unwrap_or(src.info.ts);
        let periods = src
            .info
            .columns
            .iter()
            .filter(|c| r.outputs.contains(&c.name))
            .filter_map(|c| c.period);
        let align = ranges::frame(periods, r.hold.unwrap_or(1));
        let (k0, k1) = ranges::rows_of_range(range, ts, src.info.rows, align, what)?;
        ranges::slice_file(&src.path, &src.folder, &src.name, k0, k1)
    }

    /// The data a request validates on: the validation record (else the
    /// estimation record), or the file of its validation range; its name,
    /// path and upload folder.
    pub(super) fn validation_source(&self, r: &Request) -> CliResult<(String, PathBuf, PathBuf)> {
        let src = match &self.validation {
            Some(v) => v,
            None => self.record()?,
        };
        match r.validation_range {
            Some(range) => {
                let (name, path) = self.range_file(src, range, r, "validation range")?;
                Ok((name, path, src.folder.clone()))
            }
            None => Ok((src.name.clone(), src.path.clone(), src.folder.clone())),
        }
    }

    /// The data file a request identifies on: the record, or the file of
    /// its estimation range; its name (for the command line) and path.
    pub fn estimation_source(&self, r: &Request) -> CliResult<(String, PathBuf)> {
        let rec = self.record()?;
        match r.estimation_range {
            Some(range) => self.range_file(rec, range, r, "estimation range"),
            None => Ok((rec.name.clone(), rec.path.clone())),
        }
    }

    /// Every data file a request identifies on: [`Session::estimation_source`]
    /// and the further experiments (q-Markov: one file per input, in input
    /// order), each `--data` of the command line.
    pub fn estimation_sources(&self, r: &Request) -> CliResult<Vec<(String, PathBuf)>> {
        let mut all = vec![self.estimation_source(r)?];
        all.extend(
            self.experiments
                .iter()
                .map(|e| (e.name.clone(), e.path.clone())),
        );
        Ok(all)
    }

    /// Reads the record staged at `path` (in `folder`) as a further
    /// experiment (appended; the estimation record stays the first `--data`).
    /// A file that does not read whole is removed and nothing changes.
    ///
    /// Errors: no estimation record yet, [`MAX_EXPERIMENTS`] already, the
    /// reader's error.
    pub fn adopt_experiment(&mut self, folder: PathBuf, path: PathBuf) -> CliResult<DataInfo> {
        let full = self.record().err().or_else(|| {
            (self.experiments.len() + 1 >= MAX_EXPERIMENTS).then(|| {
                input(format!(
                    "at most {MAX_EXPERIMENTS} data files per identification"
                ))
            })
        });
        if let Some(e) = full {
            let _ = std::fs::remove_dir_all(&folder);
            return Err(e);
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "experiment.csv".into());
        match self.inspect(&name, &path) {
            Ok(info) => {
                self.experiments.push(Record {
                    name,
                    folder,
                    path,
                    info: info.clone(),
                });
                self.cache.forget_identifications();
                Ok(info)
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&folder);
                Err(plain_in(&folder, e))
            }
        }
    }

    /// Stores and reads an uploaded further experiment
    /// ([`Session::adopt_experiment`]).
    pub fn upload_experiment(&mut self, name: &str, bytes: &[u8]) -> CliResult<DataInfo> {
        let (folder, path) = self.stage(name, bytes)?;
        self.adopt_experiment(folder, path)
    }

    /// Drops the further experiments.
    pub fn clear_experiments(&mut self) {
        self.cache.forget_identifications();
        for e in self.experiments.drain(..) {
            let _ = std::fs::remove_dir_all(e.folder);
        }
    }

    /// The further experiments' descriptions.
    pub fn experiments_info(&self) -> Vec<DataInfo> {
        self.experiments.iter().map(|e| e.info.clone()).collect()
    }

    /// The data file of the model of request `seq` (the record or the rows
    /// of its estimation range) and its name, for download.
    pub fn estimation_data(&self, seq: Option<u64>) -> CliResult<(String, String)> {
        let last = self.last(seq)?;
        let (name, path) = &last.data;
        let text =
            std::fs::read_to_string(path).map_err(|e| input(format!("cannot read {name}: {e}")))?;
        Ok((name.clone(), text))
    }

    /// The model of identify request `seq`, its request and command line
    /// (for the board).
    pub(crate) fn kept_model(&self, seq: u64) -> CliResult<(ModelFile, Request, String)> {
        let last = self.last(Some(seq))?;
        Ok((
            last.file.clone(),
            last.request.clone(),
            last.command.clone(),
        ))
    }

    /// The name of the record the models are validated on: the validation
    /// record when one is loaded, else the estimation record.
    pub fn validation_name(&self) -> CliResult<String> {
        match &self.validation {
            Some(v) => Ok(v.name.clone()),
            None => Ok(self.record()?.name.clone()),
        }
    }

    /// Reads the record staged at `path` (in `folder`, from
    /// [`Session::staging`]) as the validation record: once it reads whole
    /// it replaces the previous validation record (the estimation record,
    /// the models and the board stay); else `folder` is removed and nothing
    /// changes. The channels are checked when a model is validated on it.
    pub fn adopt_validation(&mut self, folder: PathBuf, path: PathBuf) -> CliResult<DataInfo> {
        self.record()?;
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "validation.csv".into());
        match self.inspect(&name, &path) {
            Ok(info) => {
                let old = self.validation.replace(Record {
                    name,
                    folder,
                    path,
                    info: info.clone(),
                });
                self.cache.forget_identifications();
                if let Some(old) = old {
                    let _ = std::fs::remove_dir_all(old.folder);
                }
                Ok(info)
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&folder);
                Err(plain_in(&folder, e))
            }
        }
    }

    /// Stores and reads an uploaded validation record ([`Session::adopt_validation`]).
    pub fn upload_validation(&mut self, name: &str, bytes: &[u8]) -> CliResult<DataInfo> {
        let (folder, path) = self.stage(name, bytes)?;
        self.adopt_validation(folder, path)
    }

    /// Drops the validation record (the models are validated on the
    /// estimation record again).
    pub fn clear_validation(&mut self) {
        self.cache.forget_identifications();
        if let Some(v) = self.validation.take() {
            let _ = std::fs::remove_dir_all(v.folder);
        }
    }

    /// The validation record's description, if any.
    pub fn validation_info(&self) -> Option<&DataInfo> {
        self.validation.as_ref().map(|r| &r.info)
    }

    /// The delay interval of every input-output pair of the record with
    /// the request's channels (thesis §4.4 per pair, as `lifted delay`
    /// with its defaults: 8 lifted lags, 3σ).
    pub fn delays(&mut self, r: &Request) -> CliResult<Delays> {
        self.check_sizes(r)?;
        let r = &self.explicit(r)?;
        let data = self.load(r)?;
        let ts = data.ts();
        let pairs = lifted_multirate::estimate_delays(data, DELAY_LAGS, DELAY_SIGMAS)
            .map_err(|e| input(format!("delay estimation: {e}")))?;
        Ok(Delays {
            base_period: ts,
            lags: DELAY_LAGS,
            sigmas: DELAY_SIGMAS,
            pairs: pairs
                .iter()
                .map(|p| PairDelay {
                    input: r.inputs.get(p.input).cloned().unwrap_or_default(),
                    output: r.outputs.get(p.output).cloned().unwrap_or_default(),
                    hold: p.hold,
                    period: p.period,
                    interval: p.interval.map(|iv| [iv.lower, iv.upper]),
                    interval_s: p
                        .interval
                        .map(|iv| [iv.lower as f64 * ts, iv.upper as f64 * ts]),
                    failure: p.failure.clone(),
                })
                .collect(),
        })
    }

    /// Records parsed and subspace compressions made by the studio's own
    /// route since the session began (the module `cached`); identifications by the
    /// command's route read the file themselves and are not counted.
    pub fn cache_counts(&self) -> (usize, usize) {
        self.cache.counts()
    }

    /// Identifications run since the session began, not counting those
    /// taken from the kept ones (the module `cached`).
    pub fn identifications_run(&self) -> usize {
        self.cache.identifications()
    }

    /// Forgets the kept identifications and validations, as a change of
    /// the further experiments or of the validation record does (the
    /// studio bench times a first visit of an order with it).
    pub fn forget_identifications(&mut self) {
        self.cache.forget_identifications();
    }

    /// The uploaded record's description, if any.
    pub fn data_info(&self) -> Option<&DataInfo> {
        self.record.as_ref().map(|r| &r.info)
    }
}
