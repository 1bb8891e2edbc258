//! The history's schema: one migration per version, applied in order.

/// The schema, one migration per version. Never edit a released migration:
/// add a new one. `PRAGMA user_version` holds how many have been applied.
pub(super) const MIGRATIONS: &[&str] = &[
    // 1: runs, scene results, per-frame metrics, stage timings, checks,
    //    regressions and trade-off points.
    r#"
    CREATE TABLE runs (
        id               INTEGER PRIMARY KEY,
        kind             TEXT NOT NULL CHECK (kind IN ('check', 'tradeoff')),
        status           TEXT NOT NULL CHECK (status IN ('running', 'passed', 'failed', 'error', 'aborted')),
        started_at       TEXT NOT NULL,
        ended_at         TEXT,
        tonegate_version TEXT NOT NULL,
        git_commit       TEXT,
        suite            TEXT,
        suite_hash       TEXT,
        adapter          TEXT,
        backend          TEXT,
        driver           TEXT,
        driver_info      TEXT,
        config           TEXT,
        host             TEXT NOT NULL,
        pid              INTEGER NOT NULL,
        pid_start        TEXT,
        detail           TEXT,
        report           TEXT
    );
    CREATE INDEX runs_by_adapter ON runs (kind, adapter, id);
    CREATE TABLE scene_results (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        test    TEXT NOT NULL,
        passed  INTEGER NOT NULL,
        fps     REAL,
        frames  INTEGER NOT NULL,
        result  TEXT NOT NULL,
        PRIMARY KEY (run_id, scene)
    );
    CREATE TABLE frame_metrics (
        run_id       INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene        TEXT NOT NULL,
        frame        INTEGER NOT NULL,
        mse          REAL,
        rmse         REAL,
        psnr         REAL,
        snr          REAL,
        ssim         REAL,
        max_abs_diff INTEGER,
        fraction_over_1lsb REAL,
        PRIMARY KEY (run_id, scene, frame)
    );
    CREATE TABLE stage_timings (
        run_id    INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene     TEXT NOT NULL,
        stage     TEXT NOT NULL,
        median_ms REAL NOT NULL,
        p95_ms    REAL NOT NULL,
        PRIMARY KEY (run_id, scene, stage)
    );
    CREATE TABLE check_results (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        idx     INTEGER NOT NULL,
        label   TEXT NOT NULL,
        passed  INTEGER,
        detail  TEXT NOT NULL,
        adapter TEXT,
        set_by  TEXT,
        PRIMARY KEY (run_id, scene, idx)
    );
    CREATE TABLE regressions (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        metric  TEXT NOT NULL,
        value   REAL NOT NULL,
        median  REAL NOT NULL,
        mad     REAL NOT NULL,
        bound   REAL NOT NULL,
        runs    INTEGER NOT NULL,
        PRIMARY KEY (run_id, scene, metric)
    );
    CREATE TABLE tradeoff_points (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        label   TEXT NOT NULL,
        config  TEXT NOT NULL,
        ms      REAL NOT NULL,
        psnr    REAL,
        ssim    REAL,
        log_average_rel_error REAL,
        pareto  INTEGER NOT NULL,
        PRIMARY KEY (run_id, scene, label)
    );
    "#,
    // 2: the mean absolute difference per frame (the `max_mean_abs_diff`
    //    check's figure); runs recorded before it have NULL there.
    r#"
    ALTER TABLE frame_metrics ADD COLUMN mean_abs_diff REAL;
    "#,
    // 3: the mean FLIP error per frame (NVIDIA's FLIP, the `max_flip_mean`
    //    check's figure).
    r#"
    ALTER TABLE frame_metrics ADD COLUMN flip_mean REAL;
    "#,
    // 4: a fleet (docs/operations.md). Runners register themselves and
    //    heartbeat; jobs are queued check runs a runner claims when its
    //    adapter and labels match the job's selector; a run says which job
    //    it ran.
    //    Times are RFC 3339 UTC text with milliseconds, which sorts as time.
    r#"
    CREATE TABLE runners (
        id         INTEGER PRIMARY KEY,
        name       TEXT NOT NULL,
        host       TEXT NOT NULL,
        pid        INTEGER NOT NULL,
        adapter    TEXT NOT NULL,
        driver     TEXT NOT NULL,
        labels     TEXT NOT NULL,
        started_at TEXT NOT NULL,
        heartbeat  TEXT NOT NULL,
        state      TEXT NOT NULL CHECK (state IN ('idle', 'busy', 'stopped', 'lost')),
        job_id     INTEGER
    );
    CREATE INDEX runners_by_state ON runners (state, heartbeat);
    CREATE TABLE jobs (
        id          INTEGER PRIMARY KEY,
        state       TEXT NOT NULL CHECK (state IN ('queued', 'claimed', 'done', 'aborted')),
        suite       TEXT NOT NULL,
        scenes      TEXT NOT NULL,
        renderer    TEXT NOT NULL,
        want_adapter TEXT,
        want_label  TEXT,
        queued_at   TEXT NOT NULL,
        claimed_at  TEXT,
        finished_at TEXT,
        runner_id   INTEGER REFERENCES runners (id),
        run_id      INTEGER REFERENCES runs (id),
        attempts    INTEGER NOT NULL,
        detail      TEXT
    );
    CREATE INDEX jobs_by_state ON jobs (state, id);
    ALTER TABLE runs ADD COLUMN job_id INTEGER REFERENCES jobs (id);
    CREATE INDEX runs_by_job ON runs (job_id);
    "#,
    // 5: artifacts in the history, content-addressed (docs/operations.md):
    //    each image once by its SHA-256, whichever runs and runners made it,
    //    and each run's names for them; `history prune` drops old runs' names
    //    and the images no kept run names.
    r#"
    CREATE TABLE blobs (
        sha256    TEXT PRIMARY KEY,
        size      INTEGER NOT NULL,
        data      BLOB NOT NULL,
        stored_at TEXT NOT NULL
    );
    CREATE TABLE run_artifacts (
        run_id INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        name   TEXT NOT NULL,
        sha256 TEXT NOT NULL REFERENCES blobs (sha256),
        PRIMARY KEY (run_id, name)
    );
    CREATE INDEX run_artifacts_by_blob ON run_artifacts (sha256);
    -- The newest check runs in id order (trends, the run list) without
    -- sorting every run: runs_by_adapter serves only an adapter's own.
    CREATE INDEX runs_by_kind ON runs (kind, id);
    "#,
    // 6: artifacts in an object store (docs/operations.md): an image kept
    //    there has its store's address here, s3://bucket/prefix, and an
    //    empty `data`; NULL keeps the image in `data`, as before.
    r#"
    ALTER TABLE blobs ADD COLUMN store TEXT;
    "#,
    // 7: an image its object store did not take (down past the retry
    //    budget, or refusing): its bytes stay in `data`, `store` says where
    //    it belongs, and `pending` why it is not there yet; NULL once it is
    //    (`tonegate history pending`).
    r#"
    ALTER TABLE blobs ADD COLUMN pending TEXT;
    "#,
    // 8: frames a user's own renderer wrote (docs/frames.md): each
    //    submission (its idempotency key, its keys, its report), the frames
    //    in it by test name and digest (the SHA-256 of the file, whose bytes
    //    are a blob), what people said of each digest of a test on a branch
    //    ('' is the main line, which every branch falls back to), every
    //    triage action in order, and the rules that ignore failures of
    //    matching tests until they expire.
    r#"
    CREATE TABLE frame_submissions (
        id              INTEGER PRIMARY KEY,
        idempotency_key TEXT UNIQUE,
        submitted_at    TEXT NOT NULL,
        keys            TEXT NOT NULL,
        passed          INTEGER NOT NULL,
        report          TEXT NOT NULL
    );
    CREATE TABLE submitted_frames (
        submission_id INTEGER NOT NULL REFERENCES frame_submissions (id) ON DELETE CASCADE,
        test          TEXT NOT NULL,
        sha256        TEXT NOT NULL REFERENCES blobs (sha256),
        verdict       TEXT NOT NULL,
        PRIMARY KEY (submission_id, test)
    );
    CREATE INDEX submitted_frames_by_blob ON submitted_frames (sha256);
    CREATE TABLE digest_labels (
        branch TEXT NOT NULL,
        test   TEXT NOT NULL,
        sha256 TEXT NOT NULL REFERENCES blobs (sha256),
        label  TEXT NOT NULL CHECK (label IN ('positive', 'negative', 'untriaged')),
        PRIMARY KEY (branch, test, sha256)
    );
    CREATE INDEX digest_labels_by_test ON digest_labels (test, branch);
    CREATE TABLE triage_log (
        id     INTEGER PRIMARY KEY,
        at     TEXT NOT NULL,
        branch TEXT NOT NULL,
        test   TEXT NOT NULL,
        sha256 TEXT NOT NULL,
        label  TEXT NOT NULL,
        who    TEXT NOT NULL,
        why    TEXT NOT NULL
    );
    CREATE TABLE ignore_rules (
        id         INTEGER PRIMARY KEY,
        pattern    TEXT NOT NULL,
        keys       TEXT NOT NULL,
        created_at TEXT NOT NULL,
        expires_at TEXT NOT NULL,
        who        TEXT NOT NULL,
        reason     TEXT NOT NULL
    );
    "#,
    // 9: a queued job's idempotency key (`POST /runs` with an
    //    `Idempotency-Key` queues a run once however often it is sent);
    //    a submission's branch as the history keys it ('' the main line),
    //    so a submission's digests can be triaged together; alerts
    //    (docs/alerts.md): each event once by its key, a delivery of it to
    //    each webhook with its state and back-off, every attempt, and the
    //    run and submission ids alerts start after (what was recorded
    //    before alerts were set up raises none).
    r#"
    ALTER TABLE jobs ADD COLUMN idempotency_key TEXT;
    CREATE UNIQUE INDEX jobs_by_idempotency_key ON jobs (idempotency_key);
    ALTER TABLE frame_submissions ADD COLUMN branch TEXT NOT NULL DEFAULT '';
    CREATE TABLE alert_events (
        id         INTEGER PRIMARY KEY,
        event_key  TEXT NOT NULL UNIQUE,
        kind       TEXT NOT NULL,
        created_at TEXT NOT NULL,
        summary    TEXT NOT NULL,
        payload    TEXT NOT NULL
    );
    CREATE TABLE alert_deliveries (
        id            INTEGER PRIMARY KEY,
        event_id      INTEGER NOT NULL REFERENCES alert_events (id) ON DELETE CASCADE,
        webhook       TEXT NOT NULL,
        state         TEXT NOT NULL CHECK (state IN ('pending', 'delivered', 'failed')),
        attempts      INTEGER NOT NULL,
        next_at       TEXT NOT NULL,
        claimed_until TEXT,
        delivered_at  TEXT,
        UNIQUE (event_id, webhook)
    );
    CREATE INDEX alert_deliveries_due ON alert_deliveries (state, next_at);
    CREATE TABLE alert_attempts (
        id          INTEGER PRIMARY KEY,
        delivery_id INTEGER NOT NULL REFERENCES alert_deliveries (id) ON DELETE CASCADE,
        at          TEXT NOT NULL,
        status      INTEGER,
        error       TEXT
    );
    CREATE TABLE alert_marks (
        name  TEXT PRIMARY KEY,
        value INTEGER NOT NULL
    );
    "#,
];

/// The schema version this build writes.
pub const SCHEMA_VERSION: i64 = MIGRATIONS.len() as i64;
