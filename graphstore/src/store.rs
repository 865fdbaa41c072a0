//! The store: one redb file, a single writer, snapshot readers.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use redb::{Database, ReadableDatabase, ReadableTable, TableHandle};

use crate::compiled::Compiled;
use crate::error::{Error, Result, storage};
use crate::index::Stack;
use crate::layout::*;
use crate::read::{GraphRead, Raw};
use crate::schema::Schema;
use crate::tokens::{TokenKind, Tokens};
use crate::txn::{ReadTxn, WriteTxn};

/// The redb handle: read-write, or read-only (never changes the file, opens files the user
/// may only read, and several processes may hold it at once).
enum Db {
    Rw(Database),
    Ro(redb::ReadOnlyDatabase),
}

impl std::fmt::Debug for Db {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Db::Rw(_) => "Db::Rw",
            Db::Ro(_) => "Db::Ro",
        })
    }
}

impl Db {
    fn begin_read(&self) -> std::result::Result<redb::ReadTransaction, redb::TransactionError> {
        match self {
            Db::Rw(d) => d.begin_read(),
            Db::Ro(d) => d.begin_read(),
        }
    }
}

#[derive(Debug)]
struct Inner {
    db: Db,
    path: PathBuf,
    /// The file's format version: [`FORMAT_VERSION`], or 1 for a store of format 1 opened
    /// read-only (read as it is, never converted).
    format: u32,
    /// The format the file had before this open converted it, if it did.
    converted_from: Option<u32>,
    writer: Mutex<()>,
    state: Mutex<Snapshot>,
}

impl Drop for Inner {
    fn drop(&mut self) {
        // the commit's read transaction ends before the database is closed
        lock(&self.state).txn = None;
    }
}

/// The last commit as readers see it: its in-memory state and one redb read transaction of it,
/// shared by every [`ReadTxn`] begun at that commit. A writer commits to redb (and waits for
/// the disk) without holding the state lock, then begins the new commit's read transaction and
/// swaps both in together: readers meanwhile keep reading the previous commit, consistent with
/// its state, instead of waiting for the disk (a slow `fdatasync` used to stall every reader).
/// A handle's snapshot changes only through its own commits: this relies on redb's default
/// `ExclusiveWriter` mode, where a writable handle is the file's only writer and a read-only
/// open excludes writers (in a mode where another process could commit, the shared read
/// transaction would keep showing the commit it began at).
#[derive(Debug)]
struct Snapshot {
    committed: Arc<Committed>,
    /// `None` until the first read after the store was opened or compacted; a writer makes
    /// one before it commits, so no reader begins a transaction between its commit and swap.
    txn: Option<Arc<redb::ReadTransaction>>,
}

impl Snapshot {
    fn new(committed: Committed) -> Mutex<Snapshot> {
        Mutex::new(Snapshot {
            committed: Arc::new(committed),
            txn: None,
        })
    }

    /// This commit's read transaction, begun now if there is none (the caller holds the state
    /// lock and no commit is under way that the state does not show).
    fn txn(&mut self, db: &Db) -> Result<Arc<redb::ReadTransaction>> {
        if let Some(t) = &self.txn {
            return Ok(t.clone());
        }
        let t = Arc::new(db.begin_read().map_err(storage)?);
        self.txn = Some(t.clone());
        Ok(t)
    }
}

/// An open store. Cheap to clone; all clones share one database.
#[derive(Debug, Clone)]
pub struct Store {
    inner: Arc<Inner>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Converts a store of an older format this build can convert (format 1: one adjacency row per
/// relationship end, see [`crate::adjacency`]) in one write transaction: all or nothing. A store
/// of this build's format, or of one it cannot convert, is left for [`Store::finish_open`] to
/// check. Whether it converted.
fn upgrade(db: &Database, path: &Path) -> Result<bool> {
    let found = {
        let rtx = db.begin_read().map_err(storage)?;
        let Ok(meta) = rtx.open_table(META) else {
            return Ok(false);
        };
        let v = meta.get(K_VERSION).map_err(storage)?;
        v.and_then(|g| format_of(g.value()).ok())
    };
    if found != Some(1) {
        return Ok(false);
    }
    let wtx = db.begin_write().map_err(storage)?;
    let ends = crate::adjacency::convert_v1(&wtx)?;
    {
        let mut meta = wtx.open_table(META).map_err(storage)?;
        meta.insert(K_VERSION, FORMAT_VERSION.to_le_bytes().as_slice())
            .map_err(storage)?;
    }
    wtx.commit().map_err(storage)?;
    tracing::info!(path = %path.display(), ends, "store converted from format 1 to {FORMAT_VERSION}");
    Ok(true)
}

/// The format version as the meta table stores it (4 bytes, little-endian).
fn format_of(bytes: &[u8]) -> Result<u32> {
    <[u8; 4]>::try_from(bytes)
        .map(u32::from_le_bytes)
        .map_err(|_| codec_err("format version", "not 4 bytes"))
}

/// The storage engine panicked reading the file's header (caught: a hostile file may only
/// ever produce an error).
fn header_unreadable(path: &Path) -> Error {
    Error::Corrupt {
        what: path.display().to_string(),
        detail: "the storage engine could not read the file header".into(),
    }
}

fn open_error(path: &Path, e: redb::DatabaseError) -> Error {
    match e {
        redb::DatabaseError::DatabaseAlreadyOpen => Error::InUse {
            path: path.to_path_buf(),
        },
        redb::DatabaseError::Storage(redb::StorageError::Corrupted(d)) => Error::Corrupt {
            what: path.display().to_string(),
            detail: d,
        },
        redb::DatabaseError::Storage(redb::StorageError::Io(io))
            if io.kind() == std::io::ErrorKind::InvalidData
                || io.kind() == std::io::ErrorKind::UnexpectedEof =>
        {
            Error::Corrupt {
                what: path.display().to_string(),
                detail: format!("not a valid store file ({io})"),
            }
        }
        other => Error::Open {
            path: path.to_path_buf(),
            reason: other.to_string(),
        },
    }
}

/// How a store is opened for writing ([`Store::create_with`]).
#[derive(Debug, Clone, Default)]
#[non_exhaustive]
pub struct StoreOptions {
    /// Bytes of the file the storage engine may keep in memory (its read cache plus the
    /// pages a write transaction holds before commit); `None`: redb's default, 1 GiB. A
    /// long batch writer that reads little back (the map build) needs far less.
    pub cache_bytes: Option<usize>,
}

impl StoreOptions {
    /// These options with the cache limited to `bytes`.
    pub fn with_cache_bytes(mut self, bytes: usize) -> Self {
        self.cache_bytes = Some(bytes);
        self
    }
}

impl Store {
    /// Opens the store at `path`, creating an empty one if the file does not exist.
    pub fn create(path: impl AsRef<Path>) -> Result<Store> {
        Self::open_inner(path.as_ref(), true, &StoreOptions::default())
    }

    /// [`Store::create`] with `options`.
    pub fn create_with(path: impl AsRef<Path>, options: &StoreOptions) -> Result<Store> {
        Self::open_inner(path.as_ref(), true, options)
    }

    /// Opens an existing store; fails if the file does not exist.
    pub fn open(path: impl AsRef<Path>) -> Result<Store> {
        let path = path.as_ref();
        if !path.exists() {
            return Err(Error::Open {
                path: path.to_path_buf(),
                reason: "no such file".into(),
            });
        }
        Self::open_inner(path, false, &StoreOptions::default())
    }

    /// Opens an existing store for reading only: the file is never written (not even its
    /// header), a file the user may only read opens, and any number of processes may read it
    /// at once. While another process holds the store for writing this fails with
    /// [`Error::InUse`]. A store left unclean by a killed writer is first recovered by one
    /// read-write open (the only case where opening for a read writes to the file). Writes
    /// through the returned handle fail with [`Error::ReadOnlyStore`].
    pub fn open_read_only(path: impl AsRef<Path>) -> Result<Store> {
        let path = path.as_ref();
        if !path.exists() {
            return Err(Error::Open {
                path: path.to_path_buf(),
                reason: "no such file".into(),
            });
        }
        let opened = std::panic::catch_unwind(|| redb::ReadOnlyDatabase::open(path));
        let db = match opened {
            Ok(Ok(db)) => db,
            Ok(Err(redb::DatabaseError::RepairAborted)) => {
                // a writer was killed: recover once with a read-write open of the file (the only
                // write a read may cause; the store's format is left as it is), then open
                // read-only
                let recovered = std::panic::catch_unwind(|| Database::open(path))
                    .map_err(|_| header_unreadable(path))
                    .and_then(|r| r.map(drop).map_err(|e| open_error(path, e)));
                if let Err(e) = recovered {
                    return Err(Error::Open {
                        path: path.to_path_buf(),
                        reason: format!(
                            "the store was not closed cleanly (a writer was killed) and needs recovery, which needs write access: {e}"
                        ),
                    });
                }
                match redb::ReadOnlyDatabase::open(path) {
                    Ok(db) => db,
                    Err(e) => return Err(open_error(path, e)),
                }
            }
            Ok(Err(e)) => return Err(open_error(path, e)),
            Err(_) => return Err(header_unreadable(path)),
        };
        Self::finish_open(Db::Ro(db), path, None)
    }

    fn open_inner(path: &Path, create: bool, options: &StoreOptions) -> Result<Store> {
        let existed = path.exists()
            && std::fs::metadata(path)
                .map(|m| m.len() > 0)
                .unwrap_or(false);
        // redb panics deep inside on some malformed headers in older versions; guard the
        // open so a hostile file can only ever produce an error.
        let opened = std::panic::catch_unwind(|| {
            let mut builder = Database::builder();
            if let Some(bytes) = options.cache_bytes {
                builder.set_cache_size(bytes);
            }
            if create {
                builder.create(path)
            } else {
                builder.open(path)
            }
        });
        let mut db = match opened {
            Ok(r) => r.map_err(|e| open_error(path, e))?,
            Err(_) => return Err(header_unreadable(path)),
        };
        // look with a read transaction: opening a store that is already one writes nothing
        let fresh = {
            let rtx = db.begin_read().map_err(storage)?;
            let names: Vec<String> = rtx
                .list_tables()
                .map_err(storage)?
                .map(|h| h.name().to_string())
                .collect();
            if !names.iter().any(|n| n == META.name()) {
                if existed && !names.is_empty() {
                    return Err(Error::NotAStore {
                        path: path.to_path_buf(),
                    });
                }
                true
            } else {
                false
            }
        };
        if fresh {
            let wtx = db.begin_write().map_err(storage)?;
            {
                let mut meta = wtx.open_table(META).map_err(storage)?;
                meta.insert(K_MAGIC, MAGIC).map_err(storage)?;
                meta.insert(K_VERSION, FORMAT_VERSION.to_le_bytes().as_slice())
                    .map_err(storage)?;
                let schema = serde_json::to_vec(&Schema::default()).map_err(storage)?;
                meta.insert(K_SCHEMA, schema.as_slice()).map_err(storage)?;
                meta.insert(K_NEXT_NODE, 0u64.to_le_bytes().as_slice())
                    .map_err(storage)?;
                meta.insert(K_NEXT_REL, 0u64.to_le_bytes().as_slice())
                    .map_err(storage)?;
                wtx.open_table(TOKENS).map_err(storage)?;
                wtx.open_table(NODES).map_err(storage)?;
                wtx.open_table(RELS).map_err(storage)?;
                wtx.open_table(ADJ).map_err(storage)?;
                wtx.open_table(LABELS).map_err(storage)?;
                wtx.open_table(PROPIDX).map_err(storage)?;
                wtx.open_table(COUNTS).map_err(storage)?;
                wtx.open_table(PAYLOADS).map_err(storage)?;
            }
            wtx.commit().map_err(storage)?;
            Self::finish_open(Db::Rw(db), path, None)
        } else if upgrade(&db, path)? {
            // the old rows' pages are free now: give them back to the file system
            db.compact().map_err(storage)?;
            Self::finish_open(Db::Rw(db), path, Some(1))
        } else {
            Self::finish_open(Db::Rw(db), path, None)
        }
    }

    /// Reads the header, tokens and schema, and builds the in-memory indexes; `converted_from`:
    /// the format this open converted the file from.
    fn finish_open(db: Db, path: &Path, converted_from: Option<u32>) -> Result<Store> {
        let rtx = match db.begin_read() {
            Ok(t) => t,
            Err(e) => return Err(storage(e)),
        };
        let meta = rtx.open_table(META).map_err(storage)?;
        let get = |k: &str| -> Result<Vec<u8>> {
            meta.get(k)
                .map_err(storage)?
                .map(|g| g.value().to_vec())
                .ok_or_else(|| Error::NotAStore {
                    path: path.to_path_buf(),
                })
        };
        if get(K_MAGIC)? != MAGIC {
            return Err(Error::NotAStore {
                path: path.to_path_buf(),
            });
        }
        let vb = get(K_VERSION)?;
        let found = format_of(&vb)?;
        // a store of format 1 is read as it is when opened read-only (a writable open has
        // converted it before this)
        let readable = found == FORMAT_VERSION || (found == 1 && matches!(db, Db::Ro(_)));
        if !readable {
            return Err(Error::FormatVersion {
                path: path.to_path_buf(),
                found,
                expected: FORMAT_VERSION,
            });
        }
        let schema: Schema = serde_json::from_slice(&get(K_SCHEMA)?)
            .map_err(|e| codec_err("schema", &e.to_string()))?;
        let mut tokens = Tokens::default();
        {
            let t = rtx.open_table(TOKENS).map_err(storage)?;
            for (i, row) in t.iter().map_err(storage)?.enumerate() {
                let (k, v) = row.map_err(storage)?;
                if k.value() as usize != i {
                    return Err(codec_err("token table", "ids are not dense"));
                }
                tokens.push(v.value().to_string());
            }
        }
        drop(meta);
        drop(rtx);
        let compiled = compile_readonly(&schema, &tokens)?;
        let store = Store {
            inner: Arc::new(Inner {
                db,
                path: path.to_path_buf(),
                format: found,
                converted_from,
                writer: Mutex::new(()),
                state: Snapshot::new(Committed {
                    tokens: Arc::new(tokens),
                    schema: Arc::new(compiled),
                    // built on first use (see MemSlot)
                    mem: MemSlot::default(),
                    seq: 0,
                    hot: Default::default(),
                    changes: Default::default(),
                }),
            }),
        };
        tracing::debug!(path = %path.display(), "store opened");
        Ok(store)
    }

    /// The file's store format version: [`FORMAT_VERSION`], or 1 for a store of format 1
    /// opened read-only, which is read as it is (a writable open converts it).
    pub fn format_version(&self) -> u32 {
        self.inner.format
    }

    /// The format version the file had before this handle's open converted it to
    /// [`FORMAT_VERSION`], if it did ([`Store::open`] converts a store of format 1).
    pub fn converted_from(&self) -> Option<u32> {
        self.inner.converted_from
    }

    /// Whether this handle was opened read-only ([`Store::open_read_only`]).
    pub fn is_read_only(&self) -> bool {
        matches!(self.inner.db, Db::Ro(_))
    }

    fn rw(&self) -> Result<&Database> {
        match &self.inner.db {
            Db::Rw(d) => Ok(d),
            Db::Ro(_) => Err(Error::ReadOnlyStore {
                path: self.inner.path.clone(),
            }),
        }
    }

    /// The file behind this store.
    pub fn path(&self) -> &Path {
        &self.inner.path
    }

    /// The declared schema.
    pub fn schema(&self) -> Schema {
        lock(&self.inner.state).committed.schema.schema.clone()
    }

    fn committed(&self) -> Arc<Committed> {
        lock(&self.inner.state).committed.clone()
    }

    /// How many commits this handle (and its clones) has made since the store was opened: a
    /// cache of what a read saw stays valid while this is unchanged. The writer holds the
    /// file, so no other process changes it meanwhile.
    pub fn commit_seq(&self) -> u64 {
        self.committed().seq
    }

    /// A consistent snapshot for reading. Writers may commit meanwhile; this reader keeps
    /// seeing the state as of now.
    pub fn read(&self) -> Result<ReadTxn> {
        let mut st = lock(&self.inner.state);
        let rtx = st.txn(&self.inner.db)?;
        let base = st.committed.clone();
        drop(st);
        ReadTxn::new(rtx, base, self.inner.format)
    }

    /// Builds the in-memory spatial, vector and text indexes now rather than on their first
    /// use (opening a store does not build them): for servers, so their first search is not
    /// slower than the rest. Reads every node with an indexed label.
    ///
    /// # Errors
    /// The store fails while reading.
    pub fn warm_indexes(&self) -> Result<()> {
        self.read()?.mem().map(|_| ())
    }

    /// Runs `f` in a write transaction. If `f` returns `Ok`, everything it did commits
    /// atomically; if it returns `Err`, nothing it did is kept and the error is returned.
    /// Only one writer runs at a time; others wait.
    pub fn write<T>(&self, f: impl FnOnce(&mut WriteTxn<'_>) -> Result<T>) -> Result<T> {
        let _writer = lock(&self.inner.writer);
        let base = self.committed();
        // the writer merges its index changes into its base's in-memory indexes, so they are
        // built first (once per store handle; the writer lock keeps the base current)
        if base.mem.get().is_none() {
            self.read()?.mem()?;
        }
        let wtx = self.rw()?.begin_write().map_err(storage)?;
        let outcome = {
            let mut tx = WriteTxn::new(&wtx, base.clone())?;
            match f(&mut tx) {
                Ok(v) => tx.finish().map(|parts| (v, parts)),
                Err(e) => Err(e),
            }
        };
        let (value, (pending, new_tokens, touched)) = match outcome {
            Ok(x) => x,
            Err(e) => {
                wtx.abort().map_err(storage)?;
                return Err(e);
            }
        };
        // Build the next index snapshot before taking the state lock so readers are not held
        // up by layer merges.
        let mem = match base.mem.get() {
            Some(m) => MemSlot::built(m.commit(pending)),
            // not built (cannot happen: see above): built from the committed data on first use
            None => MemSlot::default(),
        };
        let tokens = if new_tokens.is_empty() {
            base.tokens.clone()
        } else {
            let mut t = (*base.tokens).clone();
            for q in new_tokens {
                t.push(q);
            }
            Arc::new(t)
        };
        self.commit_and_swap(
            wtx,
            Committed {
                tokens,
                schema: base.schema.clone(),
                mem,
                seq: base.seq + 1,
                // an unlisted commit leaves no way to bring earlier copies up to date
                hot: if touched.is_some() {
                    crate::hot::Hot::after(&base.hot, base.seq)
                } else {
                    Default::default()
                },
                changes: base.changes.then(base.seq + 1, touched),
            },
        )?;
        Ok(value)
    }

    /// Replaces the schema with `schema`, checking every existing node and relationship
    /// against it and rebuilding the indexes. Fails, changing nothing, if any data breaks a
    /// rule.
    pub fn set_schema(&self, schema: Schema) -> Result<()> {
        schema.validate()?;
        let _writer = lock(&self.inner.writer);
        let base = self.committed();
        let wtx = self.rw()?.begin_write().map_err(storage)?;
        let outcome = (|| {
            let mut tx = WriteTxn::new(&wtx, base.clone())?;
            let compiled = tx.install_schema(&schema)?;
            let (_, new_tokens, _) = tx.finish()?;
            Ok::<_, Error>((compiled, new_tokens))
        })();
        let (compiled, new_tokens) = match outcome {
            Ok(x) => x,
            Err(e) => {
                wtx.abort().map_err(storage)?;
                return Err(e);
            }
        };
        let mut t = (*base.tokens).clone();
        for q in new_tokens {
            t.push(q);
        }
        // the in-memory indexes are rebuilt from the new data on first use
        self.commit_and_swap(
            wtx,
            Committed {
                tokens: Arc::new(t),
                schema: compiled,
                mem: MemSlot::default(),
                seq: base.seq + 1,
                hot: Default::default(),
                // every node is checked again, some rewritten: not listed
                changes: base.changes.then(base.seq + 1, None),
            },
        )
    }

    /// Commits `wtx` (the caller holds the writer lock), then makes `next` and a read
    /// transaction of the new commit what readers see, together ([`Snapshot`]). Readers are
    /// not held up while redb writes and syncs: until the swap they read the previous commit
    /// through its own read transaction, which this makes first if there is none yet (if that
    /// fails, nothing is committed). The commit stands once redb has it: if the new read
    /// transaction cannot be begun, the state is swapped in without one and the next reader
    /// begins it (or reports why it cannot).
    fn commit_and_swap(&self, wtx: redb::WriteTransaction, next: Committed) -> Result<()> {
        if let Err(e) = lock(&self.inner.state).txn(&self.inner.db) {
            if let Err(a) = wtx.abort() {
                tracing::warn!(error = %a, "aborting a write whose snapshot could not be read");
            }
            return Err(e);
        }
        wtx.commit().map_err(storage)?;
        let txn = match self.inner.db.begin_read() {
            Ok(t) => Some(Arc::new(t)),
            Err(e) => {
                tracing::warn!(error = %e, "no read transaction of the new commit yet");
                None
            }
        };
        let mut st = lock(&self.inner.state);
        st.committed = Arc::new(next);
        st.txn = txn;
        Ok(())
    }

    /// Adds the declarations of `extra` to the current schema (see [`Schema::merge`]).
    pub fn extend_schema(&self, extra: &Schema) -> Result<()> {
        let mut s = self.schema();
        s.merge(extra);
        self.set_schema(s)
    }

    /// Label and relationship-type counts by name, sorted.
    pub fn counts(&self) -> Result<GraphCounts> {
        self.read()?.counts()
    }

    /// Checks that every index and count agrees with the data and that no relationship
    /// dangles. Returns the problems found (empty when consistent).
    pub fn check_consistency(&self) -> Result<Vec<String>> {
        crate::integrity::check(&self.read()?)
    }

    /// Compacts the file (reclaims free pages). Needs exclusive access to this handle.
    pub fn compact(&mut self) -> Result<bool> {
        let inner = Arc::get_mut(&mut self.inner)
            .ok_or_else(|| Error::Storage("compact needs the only handle to the store".into()))?;
        // redb compacts only with no read transaction live: this handle's is begun again on
        // the next read
        inner.state.get_mut().unwrap_or_else(|p| p.into_inner()).txn = None;
        match &mut inner.db {
            Db::Rw(d) => d.compact().map_err(storage),
            Db::Ro(_) => Err(Error::ReadOnlyStore {
                path: inner.path.clone(),
            }),
        }
    }
}

/// Builds the in-memory indexes from what `r` sees.
pub(crate) fn build_mem(r: &ReadTxn) -> Result<Mem> {
    let c = r.base().schema.clone();
    let mut lists = EntryLists::new(&c);
    let mut labels: Vec<u32> = c
        .spatial
        .iter()
        .map(|s| s.label)
        .chain(c.vector.iter().map(|v| v.label))
        .chain(c.text.iter().map(|t| t.label))
        .collect();
    labels.sort_unstable();
    labels.dedup();
    // only the indexed properties are decoded (an instance's other properties, its points'
    // hull and boxes, are stepped over)
    let mut keep: Vec<u32> = c
        .spatial
        .iter()
        .flat_map(|s| std::iter::once(s.position).chain(s.bbox))
        .chain(c.vector.iter().map(|v| v.key))
        .chain(c.text.iter().map(|t| t.key))
        .collect();
    keep.sort_unstable();
    keep.dedup();
    let mut seen = std::collections::HashSet::new();
    for l in labels {
        for id in r.label_scan(crate::LabelId(l))? {
            if !seen.insert(id) {
                continue;
            }
            let Some(rec) = r.load_rec_keys(id, &keep)? else {
                continue;
            };
            lists.add(&c, id, &rec);
        }
    }
    Ok(Mem {
        spatial: lists
            .spatial
            .into_iter()
            .map(|e| Stack::new((), e))
            .collect(),
        vector: lists
            .vector
            .into_iter()
            .zip(&c.vector)
            .map(|(e, v)| Stack::new(v.params, e))
            .collect(),
        text: lists.text.into_iter().map(|e| Stack::new((), e)).collect(),
    })
}

fn compile_readonly(schema: &Schema, tokens: &Tokens) -> Result<Compiled> {
    let missing = |kind: TokenKind, n: &str| Error::Corrupt {
        what: "schema".into(),
        detail: format!("{} {n:?} named by the schema has no token", kind.noun()),
    };
    Compiled::compile(
        schema,
        |n| {
            tokens
                .get(TokenKind::Label, n)
                .ok_or_else(|| missing(TokenKind::Label, n))
        },
        |n| {
            tokens
                .get(TokenKind::RelType, n)
                .ok_or_else(|| missing(TokenKind::RelType, n))
        },
        |n| {
            tokens
                .get(TokenKind::PropKey, n)
                .ok_or_else(|| missing(TokenKind::PropKey, n))
        },
    )
}

// ---- index entries derived from a node record ----
