//! The points of a long study (a sweep's grid points, a stability map's cells, a benchmark's
//! runs, a sensor sweep's cases): each computed once, kept by the caller's [`Store`] as it
//! finishes, and on a resumed study taken from it instead of computed again. What a store is
//! (a journal file for the command line, nothing for one call from Python) is the caller's.

/// Where a study's finished points are kept.
pub trait Store: Sync {
    /// The cells an earlier run left for point `index`, if it left them under `key` (what
    /// names the point: its grid values, its case).
    fn earlier(&self, index: usize, key: &str) -> Option<Vec<String>>;
    /// The cells an earlier run left for point `index` are not usable (the study's decoder
    /// refused them): the point is computed again.
    fn refused(&self, index: usize);
    /// Every point has been looked up (a store may now say what it did not use).
    fn looked_up(&self) {}
    /// How many points an earlier run left (before any is looked up).
    fn resumed(&self) -> usize {
        0
    }
    /// Keeps point `index`, named `key`, with its cells.
    fn record(&self, index: usize, key: &str, cells: &[String]) -> anyhow::Result<()>;
}

/// Point `index`, named `key`, as an earlier run left it in `store`, if `decode` accepts its cells
/// (refused cells are reported to the store: the point is computed again).
pub fn earlier<R>(
    store: &dyn Store,
    index: usize,
    key: &str,
    decode: impl FnOnce(&[String]) -> anyhow::Result<R>,
) -> Option<R> {
    let cells = store.earlier(index, key)?;
    let decoded = decode(&cells).ok();
    if decoded.is_none() {
        store.refused(index);
    }
    decoded
}

/// How a study names, writes and reads back its points: `key` names an item, `encode` gives a
/// result's cells and `decode` reads them back for an item (refusing cells no run could give).
pub struct Codec<K, E, D> {
    pub key: K,
    pub encode: E,
    pub decode: D,
}

/// `compute(i, &items[i])` for every item on `jobs` threads, the costliest first (`cost`: an
/// estimate of the run time), results in order: each kept in `store` as it finishes and taken
/// from it where an earlier run finished it and the codec accepts its cells. Once a stop is
/// requested ([`crate::cancel`]) no item starts, a result finished meanwhile is not kept (it
/// may have been cut short), and the whole is [`Cancelled`](crate::cancel::Cancelled).
pub fn map<T, R, K, E, D>(
    items: &[T],
    jobs: Option<usize>,
    cost: impl Fn(&T) -> f64,
    store: &dyn Store,
    codec: Codec<K, E, D>,
    compute: impl Fn(usize, &T) -> anyhow::Result<R> + Sync + Send,
) -> anyhow::Result<Vec<R>>
where
    T: Sync,
    R: Send,
    K: Fn(&T) -> String + Sync,
    E: Fn(&R) -> Vec<String> + Sync,
    D: Fn(&T, &[String]) -> anyhow::Result<R> + Sync,
{
    let Codec { key, encode, decode } = codec;
    let mut earlier: Vec<Option<R>> =
        items.iter().enumerate().map(|(i, t)| self::earlier(store, i, &key(t), |cells| decode(t, cells))).collect();
    store.looked_up();
    let todo: Vec<usize> = (0..items.len()).filter(|&i| earlier[i].is_none()).collect();
    let computed = crate::parallel::map_longest_first(
        &todo,
        jobs,
        |&i| cost(&items[i]),
        |_, &i| -> anyhow::Result<Option<R>> {
            if crate::cancel::requested() {
                return Ok(None);
            }
            let result = compute(i, &items[i]);
            if crate::cancel::requested() {
                return Ok(None);
            }
            let result = result?;
            store.record(i, &key(&items[i]), &encode(&result))?;
            Ok(Some(result))
        },
    )?;
    for (&i, result) in todo.iter().zip(computed) {
        earlier[i] = result?;
    }
    earlier.into_iter().collect::<Option<Vec<R>>>().ok_or_else(|| anyhow::Error::new(crate::cancel::Cancelled))
}
