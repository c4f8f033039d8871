//! The robust stage's tuning constants: what each trades and how its value was set.

/// Fewest binned pixels the robust fit works on: the stage bins by the largest power of two
/// (up to 16) that leaves at least this many (128 x 128 views: by 4, 1,024 pixels). What it
/// trades: every hypothesis and every re-solve costs in proportion to the pixels, and a coarser
/// mask keeps fewer of the query's own pixels next to an occluder or the background (the
/// reconstruction fills them); fewer pixels also leave fewer equations per coefficient. Set so
/// that a 128 x 128 query's robust fit stays well under a millisecond; not tuned further.
pub(crate) const MIN_PIXELS: usize = 512;

/// Eigenimages of the robust stage's fit (besides the mean image, capped at N - 1). What it
/// trades: each is one more unknown per re-solve (their cost grows with its square), one more
/// direction an outlier can be explained by, and M more numbers in the model; too few leave the
/// object's own detail (and a pose between the training views) unexplained, so that detail is
/// taken for an outlier and replaced by the reconstruction. Measured on COIL-20 in texture
/// scenes (refined, trained every 10 degrees, the views between; unseen mean at 0 / 20 / 40%
/// hidden, `python3 bench/scenes.py`), objects 1, 3, 6, 9, 12, 16, 18 and 19: 16 eigenimages
/// 5.25 / 11.8 / 17.9 degrees, 24 2.33 / 6.22 / 15.6, 32 1.79 / 5.66 / 14.3; the other twelve:
/// 16 1.02 / 1.52 / 6.20, 24 0.94 / 1.34 / 5.59, 32 0.91 / 1.29 / 6.14. More are not taken
/// yet: the fit then bends to explain an occluder too, so the share of the object it finds
/// shown (`Fit::shown`) stays high on views 80% hidden and their confidence with it (the
/// rendered duck of `tests.rs`, 24: 5 of 12 views off by 40-118 degrees kept a confidence of
/// 0.78-0.88).
pub(crate) const COMPONENTS: usize = 16;

/// A query goes to the robust fit when the share of its energy where its reconstruction is
/// dark exceeds this many times the training set's own level (the geometric mean of the largest
/// in-sample and the largest left-out share, see `calibrate.rs`). What it trades: lower sends
/// clean views through the robust fit (slower; their answers no longer the plain path's bits);
/// higher lets scenes pass plainly. Set on COIL-20 objects 1-6 (numpy, the same statistic):
/// in-sample at most 0.0011-0.0052, left out 0.0041-0.088, their studio views between the
/// training views 0.0013-0.0185 (at most 1.4 times the geometric mean), their texture scenes
/// (0-40% hidden) at least 0.038-0.137 (at least 2.9 times it): 2 lies between.
/// (The largest left-out share alone overstates the views between by up to 6 times: object 6's
/// 0.088 is above its scenes' 0.063.)
pub(crate) const THRESHOLD_FACTOR: f64 = 2.0;

/// Most training views left out one at a time for the threshold (taken evenly): each costs an
/// eigenspace of the others. Not tuned.
pub(crate) const LEFT_OUT: usize = 24;

/// A binned pixel is dark in a reconstruction under this share of the reconstruction's
/// brightest (the check's statistic, `super::check::dark_share`). What it trades: higher takes in the
/// object's own dim parts, where a pose between the training views leaves residual; lower leaves
/// fewer pixels to see a background in. Not tuned.
pub(crate) const DARK: f64 = 0.1;

/// Most hypotheses (the training views' own coefficients, taken evenly) scored per query. What
/// it trades: each costs one pass over the binned pixels; too few leave poses without a start
/// near them. Training views every 10 degrees give 36; not tuned.
pub(crate) const MAX_HYPOTHESES: usize = 72;

/// Hypotheses refined by re-solving (the best by their score), in a stage without a dense
/// lattice (`scan.rs`; with one, its best alone is refined). What it trades: each costs
/// [`ANNEAL`] weighted solves; one alone may be a wrong pose whose silhouette happens to fit. 3
/// against 6 on COIL-20 objects 1-6 in texture scenes (refined): no better on the whole (6:
/// object 5 at 40% hidden 2.5 against 5.2 degrees, object 3 32 against 17).
pub(crate) const REFINED: usize = 3;

/// A hypothesis's pixels that set its gain: those at least this share of its brightest. What it
/// trades: lower takes in the dark edges where a small pose error is a large ratio; higher
/// leaves few pixels for the median. Not tuned.
pub(crate) const BRIGHT: f32 = 0.3;

/// The inlier threshold while scoring hypotheses, as a share of the hypothesis's mean bright
/// pixel (in the query's gain). What it trades: a training view up to half a step from the
/// query differs from it by far more than noise, so this is loose; looser counts background of
/// the object's brightness as explained. 0.25 against 0.15 and 0.4 on COIL-20 objects 2, 3,
/// 6, 9, 11, 16 and 19 in texture scenes (refined; 0, 20 and 40% hidden): mean errors over the
/// seven 5.3, 12.8 and 20.8 degrees at 0.25; 5.7, 14.1 and 22.9 at 0.15; 6.9, 18.3 and 29.3 at
/// 0.4.
pub(crate) const COARSE: f32 = 0.25;

/// The inlier thresholds of the re-solves of a refined hypothesis, in turn, as shares of the
/// hypothesis's mean bright pixel (in the query's gain): a pixel is explained when its residual
/// is under the threshold, the coefficients are solved again on the explained ones, and the
/// last threshold marks the pixels kept. What it trades: a hypothesis is a training view up to
/// half a step from the query, which differs from it where the pose changes the image; a tight
/// threshold from the start drops exactly those pixels and leaves the fit at the training view,
/// so the threshold starts loose and tightens as the coefficients move to the query. A tighter
/// last one drops more of the object where the eigenspace reconstructs it imperfectly (its fine
/// detail, then filled by the reconstruction); a looser one keeps occluder and background pixels
/// near the object's brightness. Measured on COIL-20 objects 1-6 in texture scenes (refined,
/// 0/20/40% hidden): a last threshold of 0.1 against 0.15 and 0.2, mean errors grew with it
/// (20% hidden, objects 1, 2, 4 and 5: 1.9, 3.1 and 5.7 degrees on average, measured before
/// the penalty of `search.rs`); 0.08
/// against 0.1 lost more of the object (object 6: 9.1 against 3.2 degrees in texture alone).
pub(crate) const ANNEAL: [f32; 6] = [0.3, 0.26, 0.22, 0.18, 0.14, 0.1];

/// A group of unexplained bins on the object (the reconstruction's bright bins, connected
/// through the object alone) holding fewer than this share of them is the object's own detail
/// that the eigenspace reconstructs only roughly, and the repair keeps the query's pixels there
/// (`repair.rs`). What it trades: higher keeps more of an occluder's pieces on the object;
/// lower replaces more of a textured object's detail by the reconstruction's blur. Measured on
/// COIL-20 in texture scenes (refined, trained every 10 degrees, the views between; unseen mean
/// at 0 / 20 / 40% hidden, `python3 bench/scenes.py`), on the twelve objects other than 1, 3,
/// 6, 9, 12, 16, 18 and 19 and on those eight: no specks 1.02 / 1.52 / 6.20 and 5.23 / 11.7 /
/// 17.9; 0.05 0.87 / 1.47 / 6.11 and 3.86 / 10.2 / 17.8; 0.1 0.84 / 2.01 / 6.12 and 2.57 / 9.62
/// / 18.0; 0.025 0.92 / 1.45 / 6.13 and 3.91 / 11.1 / 17.8 (chosen with both groups in view).
/// Groups that had to lie wholly on the object (connected through the background too) gained
/// less: 0.95 / 1.47 / 6.17 and 4.55 / 11.1 / 17.9 at 0.05. Removing every unexplained stroke
/// one bin thin on the object instead (an opening) took the eight at 0% to 3.36 but the twelve
/// at 40% to 7.21: a striped occluder is such strokes too.
pub(crate) const SPECK: f64 = 0.05;

/// A bin's tolerance in the repair is at least this many times the residual that the training
/// views nearest the fit leave there off their own reconstruction (`detail.rs`), in the fit's
/// gain. What it trades: higher keeps more of the object's own detail and more of an occluder
/// that differs from the object by no more than that detail does; lower replaces more of a
/// textured object by the reconstruction's blur. Set on the development objects of COIL-20 in
/// texture scenes (1, 3, 6, 9, 12, 16, 18 and 19; refined, trained every 10 degrees, the views
/// between, `python3 bench/scenes.py`; unseen mean at 0 / 20 / 40% hidden): the threshold alone
/// 2.56 / 4.79 / 11.6 degrees, 1 1.84 / 3.23 / 10.3, 2 1.52 / 2.32 / 9.78, 3 1.47 / 2.57 / 9.52
/// (a first version looking the views up by the hypotheses' coordinates; as landed, 2 gives 1.52
/// / 2.28 / 10.0): 2, the best at 20% hidden and within 0.05 degrees of 3 with nothing hidden.
/// On the twelve other objects, not used to set it: 0.80 / 1.26 / 3.99
/// alone, 0.69 / 1.15 / 3.41 at 2 (1 0.77 / 1.21 / 3.52, 3 0.67 / 1.19 / 3.42). Taking the
/// nearest one, two, three or four training views (at 2): 1.60 / 3.50 / 10.3, 1.52 / 2.32 /
/// 9.78, 1.48 / 2.27 / 10.1, 1.46 / 2.26 / 9.57 on the development objects: P + 1, as the
/// answer's check mixes (`verify.rs`).
pub(crate) const DETAIL: f32 = 2.0;

/// The method's candidate poses of a repaired query that its check against the training views
/// compares (`verify.rs`): its estimate and its best alternatives. What it trades: each costs a
/// pass over the kept bins; more let a farther alternative win on an accident of the kept
/// pixels. 3 is eval's default `--top`, the candidates it was measured with; not tuned.
pub(crate) const ANSWERS: usize = 3;

/// An alternative candidate replaces the method's estimate of a repaired query when McNemar's
/// statistic on the kept bins one explains and the other does not, (b - c)^2 / (b + c), exceeds
/// this (`verify.rs`): the chi-square point of one degree of freedom at 5%, not tuned. What it
/// trades: lower follows the kept bins, which lean to the fit's pose, more often; higher leaves
/// more of the method's flips.
pub(crate) const DISAGREE: f64 = 3.84;

/// Binned pixels the model leaves dark in every training view (every row of the stage at most
/// this share of its largest in absolute value) are left out of the fit: they constrain no
/// coefficient, and the query's value there is explained only when dark. Not tuned.
pub(crate) const SUPPORT: f32 = 0.02;

/// The smallest and the largest scale of the object in a scene searched for (`locate.rs`), over
/// the training views' size: the issue's +-20%. What it trades: a wider range costs more
/// windows and offers more chances for clutter to look like the object. Not tuned.
pub(crate) const SCALE_LO: f64 = 0.8;
/// See [`SCALE_LO`].
pub(crate) const SCALE_HI: f64 = 1.2;

/// The ratio between neighbouring scales of the coarse search (0.8 to 1.2: 6 scales). What it
/// trades: each scale is a pass over the positions; a coarser ladder leaves the right scale's
/// window further from any scored one. 1.2 against 1.1 (with 36 coarse hypotheses, the rest as
/// below) on the development objects (see [`COARSE_HYPOTHESES`]): box centres within 3 pixels
/// 0.79 against 0.81, about 0.6 times the time.
pub(crate) const SCALE_RATIO: f64 = 1.1;

/// The coarse search's grid step, as a share of its cell (2b pixels at scale 1). What it
/// trades: the windows scored grow with the inverse square. 0.5 against 1 (the score then
/// counting the backdrop, before [`SILHOUETTE`]): 0.59 against 0.56 within 3 pixels at 3.8 times
/// the time.
pub(crate) const STRIDE: f64 = 1.0;

/// Coarse windows refined, the best ones at least [`APART`] of a window's smaller side apart
/// (each from itself and from the four windows a coarse step from it). What it trades: each
/// costs five pattern searches on the stage's cells; too few lose the object when clutter
/// outscores it at the coarse resolution, which it often does (the object's coarse score ranked
/// below clutter's in 6 of 6 failures examined). 8 against 3: 0.61 against 0.56 within 3 pixels
/// (the score counting the backdrop, one start each). With the score and the five starts of
/// now, all 20 COIL-20 objects in 320 x 240 texture scenes, nothing hidden (`python3
/// bench/locate.py`): 8 against 4, boxes within 3 pixels 0.944 against 0.942, unseen mean 2.32
/// against 2.71 degrees, at about 1.4 times the time of a scene.
pub(crate) const CANDIDATES: usize = 8;
/// See [`CANDIDATES`]. Not tuned.
pub(crate) const APART: f64 = 0.25;

/// Coarse windows more than this many steps of [`SCALE_RATIO`] apart in scale are apart wherever
/// they lie (see [`CANDIDATES`]): at one place a cup's bowl, matched at a smaller scale by a view
/// whose handle hides, and the whole cup are two candidates. What it trades: fewer steps let
/// the one object's neighbouring scales take the candidates' places; more leave the part and
/// the whole as one. 2, not tuned, made for COIL-20 object 18 (the cup): on all 20 objects in
/// 320 x 240 texture scenes (`python3 bench/locate.py`, with [`LOOSE_CANDIDATES`]) boxes within
/// 3 pixels 0.956 / 0.846 / 0.440 to 0.965 / 0.872 / 0.476 at 0 / 20 / 40% hidden, unseen mean
/// 1.78 / 11.1 / 50.3 to 1.42 / 9.90 / 47.4 degrees (object 18 18.1 to 10.8 with nothing
/// hidden); on the 17 objects other than 4, 5 and 18, 0.967 / 0.858 to 0.974 / 0.882 at 0 / 20%
/// hidden, and 0.93 / 10.55 to 0.95 / 9.30 degrees. The same steps tell the part from the
/// whole when the refined windows are arbitrated (`locate.rs`, step 3).
pub(crate) const APART_SCALE_STEPS: f64 = 2.0;

/// Coarse windows refined besides the [`CANDIDATES`], the best by their score within the
/// hypotheses' envelopes (a window up to half a cell off the object read as the object; apart as
/// those are). The coarse score of a textured object falls off within a few pixels, less than
/// the coarse step, so the grid can miss its peak while clutter's broad peaks outrank it: the
/// envelopes' score does not miss it, but alone it lets clutter in (all 20 COIL-20 objects in
/// 320 x 240 texture scenes, nothing hidden, as the only ranking, with each cell's least and
/// most value for the envelope: boxes within 3 pixels 0.953 to 0.907). What it trades: each costs one pattern search on the stage's cells, and the coarse
/// pass scores each window twice (one 320 x 240 scene 31.8 to 34.8 ms, `cargo bench -p linpose
/// --bench scene`). 4, not tuned, made for objects 4 and 5, whose boxes the grid missed: on all
/// 20 (`python3 bench/locate.py`) boxes within 3 pixels 0.953 / 0.836 / 0.430 to 0.956 / 0.846
/// / 0.440 at 0 / 20 / 40% hidden, unseen mean 2.02 / 12.2 / 51.8 to 1.78 / 11.1 / 50.3 degrees
/// (object 5 6.09 to 1.19 with nothing hidden); on the 17 others 0.966 / 0.852 to 0.967 / 0.858,
/// and 0.93 / 10.56 to 0.93 / 10.55 degrees.
pub(crate) const LOOSE_CANDIDATES: usize = 4;

/// The fine search stops when its position step is under this many pixels. What it trades:
/// each halving is up to six more windows scored. Not tuned.
pub(crate) const MIN_SHIFT: f64 = 0.25;

/// Most windows one fine search scores (a bound on its cost). Not tuned.
pub(crate) const MAX_EVALUATIONS: usize = 60;

/// Hypotheses of the coarse search (the stage's, taken evenly). What it trades: each is a pass
/// over every window. Set on COIL-20 objects 2, 3, 5, 9 and 19 (the development objects: the
/// five with the most misplaced boxes at first) in 320 x 240 texture scenes at scale 0.8-1.2,
/// nothing hidden, with the settings here otherwise: box centres within 3 pixels on 0.78 of
/// their views with 18, 0.81 with 36 at twice the time.
pub(crate) const COARSE_HYPOTHESES: usize = 18;

/// Hypotheses of a fine search: those that explain its start best. What it trades: each is a
/// pass per window scored; one alone may be a pose that fits best slightly off the object's
/// place. Not tuned.
pub(crate) const FINE_HYPOTHESES: usize = 3;

/// Neighbours in the eigenspace of each hypothesis of a fine search whose pose halfway to it is
/// scored too (`locate.rs`, `Level::around`). What it trades: each adds a hypothesis to every
/// window the fine search scores; with none, a query between two training views is placed by
/// the nearer view alone, a few pixels off where the pose moves the object in the frame. Set on
/// COIL-20 in 320 x 240 texture scenes (`python3 bench/locate.py`, all 20 objects, nothing
/// hidden; box centres within 3 pixels): 0.887 with none, 0.903 with 2 (and 0.905 with the
/// quarter-way poses too); the rest of the search as here, before [`POLISH`]. On data it was
/// not set on: see [`POLISH`].
pub(crate) const NEIGHBOURS: usize = 2;

/// Rounds of the search's polish (`locate.rs`): the robust fit of the box found, then a pattern
/// search with its reconstruction as the one hypothesis. What it trades: each round is one
/// robust fit (about a millisecond for 128 x 128 views) and a short pattern search; the
/// reconstruction follows a pose between the training views, which the training views' own
/// images do not. Developed on COIL-20's 320 x 240 texture scenes, nothing hidden, with
/// [`NEIGHBOURS`] 2: within 3 pixels 0.903 with none, 0.912 with 1, 0.915 with 2. The two
/// together on the 13 objects outside the search's development objects (2, 3, 5, 9 and 19)
/// and the two examined for the failures (6, 18), at 0 / 20 / 40% hidden: boxes within 3
/// pixels 0.967 / 0.858 / 0.453 without them, 0.983 / 0.886 / 0.471 with them; unseen mean
/// 3.25 / 13.7 / 49.2 degrees against 1.74 / 12.2 / 46.3. The search and repair of one scene
/// (`cargo bench -p linpose --bench scene`, the duck): 17.3 against 20.5 ms.
pub(crate) const POLISH: usize = 2;

/// A hypothesis's silhouette for the search's score: its cells above this share of its
/// brightest (its rim, the cells just outside, count against a window whose scene goes on like
/// the object there; `locate.rs`). What it trades: the other cells it leaves out count nothing
/// either way; counting every cell (the robust fit's score, where the backdrop is the training
/// views') lets dark clutter that matches the backdrop outscore the object. On the development objects (see
/// [`COARSE_HYPOTHESES`]), with 36 hypotheses: 0.81 within 3 pixels at 0.1 against 0.72 counting
/// every cell; with 3 candidates: 0.05 gave 0.61, 0.1 0.63, 0.3 0.54 (all before the rim and the
/// share of the silhouette, with a sum over its cells).
pub(crate) const SILHOUETTE: f32 = 0.1;

/// Training views (taken evenly) that the hidden-share calibration hides (`hidden.rs`). What it
/// trades: each is [`HIDDEN_SHARES`] x [`HIDDEN_DRAWS`] robust fits when the stage is fitted;
/// fewer leave the logistic's two numbers resting on fewer outcomes. Not tuned: 36 (every
/// training view of a turntable every 10 degrees) costs 0.2 s of CPU for a COIL-20 object
/// (128 x 128, binned by 4), about half its whole `train --robust` of the eigenspace.
pub(crate) const HIDDEN_VIEWS: usize = 36;

/// The shares of a view's bright pixels the calibration's rectangle hides. From none (clutter
/// only) to past what most objects can be read from, evenly, so that the logistic sees both
/// ends. Not tuned.
pub(crate) const HIDDEN_SHARES: [f64; 5] = [0.0, 0.2, 0.4, 0.6, 0.8];

/// Draws (clutter, side, fill) per view and share in the calibration. Not tuned.
pub(crate) const HIDDEN_DRAWS: usize = 2;

/// The calibration puts clutter where a training view is darker than this share of its
/// brightest (the backdrop: studio views have a dark one); the object's own dark parts above it
/// stay. What it trades: higher punches the clutter into the object's dark parts (the fit then
/// shows less of the object than a scene's would), lower leaves the dim rim of the backdrop.
/// Not tuned.
pub(crate) const OBJECT: f32 = 0.02;

/// The range of the gain of the calibration's clutter (another training view, shifted) against
/// the view's own brightness. Not tuned.
pub(crate) const CLUTTER_GAIN: [f32; 2] = [0.3, 1.0];

/// For a stage of a model file written before the hidden-share calibration: a repaired query
/// showing at most this share of its object's expected bright pixels gets confidence 0. Set by
/// eye on the rendered duck (64 x 48, trained every 10 degrees, queried between in texture
/// scenes: 12 views 10% hidden showed 0.53-0.71, 12 views 80% hidden 0.19-0.46), kept only so
/// that such files answer as they did.
pub(crate) const LEGACY_SHOWN_LOW: f64 = 0.3;

/// See [`LEGACY_SHOWN_LOW`]: at least this share keeps the method's confidence; between the two
/// it is scaled linearly.
pub(crate) const LEGACY_SHOWN_HIGH: f64 = 0.5;

/// How many times a repaired query's answer is read again from its own pixels (`reread.rs`),
/// the bins it shows found again at each new pose. What it trades: each costs a climb of a few
/// surface evaluations; one leaves the bins found at a pose up to a few degrees off. Not tuned
/// (the prototype's 3; the reading stops as soon as the pose no longer moves).
pub(crate) const REREADS: usize = 3;

/// The lattice (degrees) the reread climbs on (`reread.rs`): the eigenspace's manifold step
/// and the refined method's default reporting lattice (the paper's 0.5 degrees). Not tuned.
pub(crate) const REREAD_STEP: f64 = 0.5;

/// The settle's first step for the box's centre (`settle.rs`), in pixels at scale 1 (the pose's
/// first step is twice [`REREAD_STEP`], the scale's half a step of [`SCALE_RATIO`]). What it
/// trades: larger steps jump farther from the search's box at more evaluations a halving. Not
/// tuned.
pub(crate) const SETTLE_SHIFT: f64 = 1.0;

/// Levels of the settle's steps (`settle.rs`), each at half the steps of the one before: from
/// [`SETTLE_SHIFT`] to a quarter of it, from a degree to a quarter. What it trades: each level is
/// one more sweep of 2 (P + 3) evaluations at least. Not tuned.
pub(crate) const SETTLE_LEVELS: usize = 3;

/// The dense first pass (`scan.rs`): its views per training interval of each pose parameter.
/// What it trades: each is one more hypothesis scored per query (a pass over the binned pixels
/// and its neighbourhoods); fewer leave the query further from the nearest view, whose misses
/// then blur the details the tight threshold is there to see. Not tuned; in the numpy prototype
/// of the pass (COIL-20 objects 1, 3, 6, 9, 12, 16, 18 and 19 in texture scenes, 40% hidden, the
/// interpolated views scored as `scan.rs` scores them), views every 2.5 degrees (4 per interval)
/// against every 5 and every 10: 9, 15 and 31 gross errors of 288.
pub(crate) const LATTICE_STEPS: usize = 4;

/// The dense first pass holds at most this many views (fewer per interval when more would be
/// needed; with two or three pose parameters, often the training views alone). What it trades:
/// memory (the views and their coefficients, M_b + K numbers each, none in the model file) and
/// time per query, both in proportion. Sixteen times the 36 views of a ring at 10 degrees; not
/// tuned.
pub(crate) const LATTICE_MOST: usize = 576;

/// The dense first pass's threshold, as a share of a hypothesis's mean bright pixel (in the
/// query's gain): the refine's last ([`ANNEAL`]'s), as it was not tuned for itself. What it
/// trades: tighter drops the object's own pixels where the interpolation misses them (more than
/// the details that tell two sides apart); looser lets clutter of the object's brightness
/// count. In the numpy prototype (as for [`LATTICE_STEPS`]), 0.08, 0.1, 0.12 and 0.15: 15, 9,
/// 8 and 17 gross errors of 288; the same count unweighed, at 0.1: 32. On the twelve other
/// objects (not used to choose it): 3 gross errors of 432 at 0.1 and at 0.12. In linpose
/// (`bench/scenes.py`, refined `--robust`, all 20 objects, 0 / 20 / 40% hidden): 0.92 / 1.08 /
/// 2.67 degrees against 0.92 / 1.16 / 4.96 with the training views' coefficients scored within
/// [`COARSE`].
pub(crate) const SCAN: f32 = 0.1;
