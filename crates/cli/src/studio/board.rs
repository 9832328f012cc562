//! The model board (MATLAB's ident "model board"): the models the user
//! keeps, each with the options it was identified with, compared on the
//! validation data: a fit table over every model, and for the selected
//! ones the simulated outputs over the measured ones, the step responses
//! and the Bode plots, overlaid. Any kept model can be saved
//! (`GET /api/model?board=ID`) or removed.

use lifted_lti::{ModelFile, StateSpace};
use serde::{Deserialize, Serialize};

use crate::error::{CliResult, input};
use crate::plot::{Marker, Plot, Series, svg};
use crate::service::figures::{Window, bode_grid, decimate_in};
use crate::service::pairs::{bode_pairs, pairs_svg, step_pairs};
use crate::studio::session::{Request, Session};

/// Models kept on the board at most.
pub const MAX_BOARD: usize = 16;

/// A model kept on the board.
pub(crate) struct Pinned {
    pub id: u64,
    pub label: String,
    pub command: String,
    pub file: ModelFile,
    pub request: Request,
}

/// A call of `POST /api/board`: keep the model of the page's request
/// `add` (its sequence number), remove the kept model `remove`, and show
/// the board with the models `selected` overlaid (time plots over
/// `window`). Every field is optional.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardRequest {
    /// Keep the model of this identify request (sequence number).
    pub add: Option<u64>,
    /// Remove the kept model of this id.
    pub remove: Option<u64>,
    /// Ids of the models drawn in the overlays (none: the table only).
    pub selected: Vec<u64>,
    /// Time window of the overlaid outputs, seconds.
    pub window: Option<[f64; 2]>,
}

/// One kept model in the fit table.
#[derive(Debug, Clone, Serialize)]
pub struct BoardEntry {
    /// The board's id of the model.
    pub id: u64,
    /// Short label: `#id method order …`.
    pub label: String,
    /// The command line that writes this model.
    pub command: String,
    /// Whether it is stable (ρ(A) < 1).
    pub stable: bool,
    /// Simulation fit % per output on the validation data (`null` when
    /// not meaningful: unstable, non-finite).
    pub fits: Vec<(String, Option<f64>)>,
    /// Whether it is drawn in the overlays.
    pub selected: bool,
}

/// The board as the page shows it.
#[derive(Debug, Clone, Serialize)]
pub struct BoardView {
    /// The record the fits are computed on (the validation record if one
    /// is loaded, else the estimation record).
    pub data: String,
    /// The kept models, oldest first.
    pub entries: Vec<BoardEntry>,
    /// Per output: measured and each selected model's simulated output.
    pub response: Vec<String>,
    /// Step responses of the selected models (SVG), if any is selected.
    pub step: Option<String>,
    /// Bode magnitude over phase of the selected models, if any.
    pub bode: Option<String>,
}

/// A short label of a kept model from its request.
fn label_of(id: u64, file: &ModelFile, r: &Request) -> String {
    let mut l = format!(
        "#{id} {} n={}",
        file.method.clone().unwrap_or_default(),
        file.model.order()
    );
    let horizon = lifted_workflow::Diagnostics::of(file)
        .horizons
        .and_then(|h| h.first().copied())
        .or(r.horizon);
    if let Some(h) = horizon {
        l += &format!(" h={h}");
    }
    if let Some(q) = r.q {
        l += &format!(" q={q}");
    }
    if r.refine.is_some() {
        l += " pem";
    }
    if r.stable {
        l += " stable";
    }
    l
}

impl Session {
    /// Applies a board call (keep, remove) and returns the board.
    ///
    /// Errors: no model of request `add` (or none at all), a full board
    /// ([`MAX_BOARD`]), no kept model `remove`, a bad window.
    pub fn board(&mut self, b: &BoardRequest) -> CliResult<BoardView> {
        let mut selected = b.selected.clone();
        if let Some(seq) = b.add {
            let (file, request, command) = self.kept_model(seq)?;
            if self.board.len() >= MAX_BOARD {
                return Err(input(format!(
                    "the board holds at most {MAX_BOARD} models: remove one first"
                )));
            }
            self.board_ids += 1;
            let id = self.board_ids;
            self.board.push(Pinned {
                id,
                label: label_of(id, &file, &request),
                command,
                file,
                request,
            });
            // A model just kept is drawn.
            selected.push(id);
        }
        if let Some(id) = b.remove {
            let before = self.board.len();
            self.board.retain(|p| p.id != id);
            if self.board.len() == before {
                return Err(input(format!("no model #{id} on the board")));
            }
        }
        let window = crate::studio::session::window_of_pair(b.window)?;
        self.board_view(&selected, window)
    }

    fn board_view(&mut self, selected: &[u64], window: Window) -> CliResult<BoardView> {
        let data_name = self.validation_name()?;
        let mut entries = Vec::new();
        // (output name, ts, measured instants and values, [(label, simulated)]).
        type Overlay = (String, f64, Vec<f64>, Vec<f64>, Vec<(String, Vec<f64>)>);
        let mut overlays: Vec<Overlay> = Vec::new();
        let pinned: Vec<(u64, String, String, ModelFile, Request)> = self
            .board
            .iter()
            .map(|p| {
                (
                    p.id,
                    p.label.clone(),
                    p.command.clone(),
                    p.file.clone(),
                    p.request.clone(),
                )
            })
            .collect();
        let mut models = Vec::new();
        for (id, label, command, file, request) in pinned {
            let shown = selected.contains(&id);
            // A model whose channels the current data lack stays on the
            // board, without fits.
            let (data, v) = match self.validated(&file, &request, super::session::SLIDER_HORIZONS) {
                Ok((_, data, v)) => (data, v),
                Err(e) => {
                    entries.push(BoardEntry {
                        id,
                        label: format!("{label} (not on this data: {e})"),
                        command,
                        stable: file.model.is_stable(0.0).unwrap_or(false),
                        fits: Vec::new(),
                        selected: false,
                    });
                    continue;
                }
            };
            let stable = v.stable();
            let fits = v
                .outputs
                .iter()
                .map(|o| {
                    let ok = stable && o.residual_finite && o.fit.is_finite();
                    (o.name.clone(), ok.then_some(o.fit))
                })
                .collect();
            if shown {
                let ts = data.ts();
                for o in &v.outputs {
                    let at = match overlays.iter().position(|x| x.0 == o.name) {
                        Some(i) => i,
                        None => {
                            let t: Vec<f64> = o.instants.iter().map(|&k| k as f64 * ts).collect();
                            overlays.push((o.name.clone(), ts, t, o.measured.clone(), Vec::new()));
                            overlays.len() - 1
                        }
                    };
                    let sim = if o.residual_finite {
                        o.simulated.clone()
                    } else {
                        vec![f64::NAN; o.simulated.len()]
                    };
                    overlays[at].4.push((label.clone(), sim));
                }
                models.push((label.clone(), file.model.clone()));
            }
            entries.push(BoardEntry {
                id,
                label,
                command,
                stable,
                fits,
                selected: shown,
            });
        }
        let mut response = Vec::new();
        for (name, ts, mt, my, sims) in overlays {
            let slow = mt.len() < sims.first().map_or(0, |s| s.1.len());
            let (mt, my) = decimate_in(&mt, &my, window);
            let mut plot = Plot {
                title: format!("{name}: measured and the selected models (simulated)"),
                x_label: "t [s]".into(),
                y_label: name.clone(),
                series: vec![if slow {
                    Series::points("measured", mt, my, Marker::Dot)
                } else {
                    Series::line("measured", mt, my)
                }],
                ..Default::default()
            };
            for (label, sim) in sims {
                let t: Vec<f64> = (0..sim.len()).map(|k| k as f64 * ts).collect();
                let (t, s) = decimate_in(&t, &sim, window);
                plot.series.push(Series::line(label, t, s));
            }
            response.push(svg(&plot, 900, 280)?);
        }
        let (step, bode) = if models.is_empty() {
            (None, None)
        } else {
            let omega = bode_grid(&models[0].1, None, None, 200)?;
            let drawn: Vec<(String, &StateSpace)> =
                models.iter().map(|(l, m)| (l.clone(), m)).collect();
            let step = pairs_svg(&step_pairs(&drawn)?, 560, 240)?;
            let bode = pairs_svg(&bode_pairs(&drawn, &omega)?, 560, 200)?;
            (Some(step), Some(bode))
        };
        Ok(BoardView {
            data: data_name,
            entries,
            response,
            step,
            bode,
        })
    }

    /// The model file of a kept model, as the command's model-file JSON.
    pub fn board_model_json(&self, id: u64) -> CliResult<String> {
        let p = self
            .board
            .iter()
            .find(|p| p.id == id)
            .ok_or_else(|| input(format!("no model #{id} on the board")))?;
        p.file
            .to_json()
            .map_err(|e| input(format!("model file: {e}")))
    }
}
