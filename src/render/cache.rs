//! The result cache behind the pass graph: every stage's output (a loaded dataset, a GPU upload,
//! a ray-cast image, a tone-mapped image) is stored under a 64-bit hash of everything it was
//! computed from, within a memory budget, evicting the least recently used entry first. A change
//! to one input therefore re-runs only the stages whose keys it changes.

use std::any::Any;
use std::collections::HashMap;
use std::hash::Hasher;
use std::sync::{Arc, Mutex};

/// Default budget: enough for a 513³ f32 volume on the host and on the GPU plus a sweep's images.
pub(crate) const DEFAULT_BUDGET_MIB: u64 = 2048;

/// Environment variable with the result-cache budget in MiB when `--cache-mib` is not given.
pub(crate) const BUDGET_ENV: &str = "HDRVIS_CACHE_MIB";

/// The budget in MiB: the explicit value, else `HDRVIS_CACHE_MIB`, else `DEFAULT_BUDGET_MIB`.
pub fn budget_mib(explicit: Option<u64>) -> crate::Result<u64> {
    match explicit {
        Some(v) => Ok(v),
        None => match std::env::var(BUDGET_ENV) {
            Ok(v) => v.trim().parse::<u64>().map_err(|_| {
                crate::Error::invalid(
                    BUDGET_ENV,
                    format!("expected a whole number of MiB, got {v:?}"),
                )
            }),
            Err(_) => Ok(DEFAULT_BUDGET_MIB),
        },
    }
}

/// A hash of stage inputs, built field by field (xxh3: fast enough to hash whole volumes).
#[derive(Default)]
pub(crate) struct KeyBuilder(xxhash_rust::xxh3::Xxh3);

impl KeyBuilder {
    pub(crate) fn new(stage: &str) -> Self {
        let mut k = KeyBuilder(xxhash_rust::xxh3::Xxh3::new());
        k.str(stage);
        k
    }

    pub(crate) fn str(&mut self, s: &str) -> &mut Self {
        self.u64(s.len() as u64);
        self.0.write(s.as_bytes());
        self
    }

    pub(crate) fn u64(&mut self, v: u64) -> &mut Self {
        self.0.write(&v.to_le_bytes());
        self
    }

    pub(crate) fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.u64(b.len() as u64);
        self.0.write(b);
        self
    }

    /// Any value through its `Debug` form: Rust prints floats with the shortest digits that
    /// round-trip, so two option sets hash alike only if every field is bit-for-bit equal.
    pub(crate) fn debug(&mut self, v: &impl std::fmt::Debug) -> &mut Self {
        self.str(&format!("{v:?}"))
    }

    pub(crate) fn finish(&self) -> u64 {
        self.0.digest()
    }
}

struct Entry {
    value: Arc<dyn Any + Send + Sync>,
    bytes: u64,
    last_use: u64,
}

/// Counters for tests and `--stats`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheCounters {
    pub hits: u64,
    pub misses: u64,
    pub evictions: u64,
    pub entries: usize,
    pub bytes: u64,
}

/// Least-recently-used store of stage results, bounded in bytes.
pub struct ResultCache {
    budget: u64,
    inner: Mutex<Inner>,
}

#[derive(Default)]
struct Inner {
    entries: HashMap<u64, Entry>,
    clock: u64,
    bytes: u64,
    hits: u64,
    misses: u64,
    evictions: u64,
}

impl ResultCache {
    pub fn new(budget_bytes: u64) -> Self {
        ResultCache {
            budget: budget_bytes,
            inner: Mutex::new(Inner::default()),
        }
    }

    pub fn budget(&self) -> u64 {
        self.budget
    }

    /// The value stored under `key`, if any and of type `T`; a hit makes it the most recent.
    pub fn get<T: Any + Send + Sync>(&self, key: u64) -> Option<Arc<T>> {
        let mut inner = self.inner.lock().expect("result cache poisoned");
        inner.clock += 1;
        let now = inner.clock;
        let found = inner.entries.get_mut(&key).and_then(|e| {
            e.last_use = now;
            e.value.clone().downcast::<T>().ok()
        });
        if found.is_some() {
            inner.hits += 1;
        } else {
            inner.misses += 1;
        }
        found
    }

    /// Stores `value` (of `bytes` bytes) under `key`, evicting least recently used entries until
    /// it fits; a value larger than the whole budget is not stored.
    pub(crate) fn put<T: Any + Send + Sync>(&self, key: u64, value: Arc<T>, bytes: u64) {
        if bytes > self.budget {
            return;
        }
        let mut inner = self.inner.lock().expect("result cache poisoned");
        if let Some(old) = inner.entries.remove(&key) {
            inner.bytes -= old.bytes;
        }
        while inner.bytes + bytes > self.budget {
            let Some((&victim, _)) = inner.entries.iter().min_by_key(|(_, e)| e.last_use) else {
                break;
            };
            let e = inner.entries.remove(&victim).expect("victim exists");
            inner.bytes -= e.bytes;
            inner.evictions += 1;
        }
        inner.clock += 1;
        let last_use = inner.clock;
        inner.bytes += bytes;
        inner.entries.insert(
            key,
            Entry {
                value,
                bytes,
                last_use,
            },
        );
    }

    /// Drops the entries of type `T` for which `drop(key, value)` holds.
    pub(crate) fn remove_where<T: Any + Send + Sync>(&self, drop: impl Fn(u64, &T) -> bool) {
        let mut inner = self.inner.lock().expect("result cache poisoned");
        let victims: Vec<u64> = inner
            .entries
            .iter()
            .filter(|(k, e)| e.value.downcast_ref::<T>().is_some_and(|v| drop(**k, v)))
            .map(|(k, _)| *k)
            .collect();
        for k in victims {
            let e = inner.entries.remove(&k).expect("victim exists");
            inner.bytes -= e.bytes;
        }
    }

    pub fn counters(&self) -> CacheCounters {
        let inner = self.inner.lock().expect("result cache poisoned");
        CacheCounters {
            hits: inner.hits,
            misses: inner.misses,
            evictions: inner.evictions,
            entries: inner.entries.len(),
            bytes: inner.bytes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_recently_used_entry_is_evicted_first() {
        let c = ResultCache::new(100);
        c.put(1, Arc::new(1u32), 40);
        c.put(2, Arc::new(2u32), 40);
        assert_eq!(c.get::<u32>(1).as_deref(), Some(&1)); // 1 is now more recent than 2
        c.put(3, Arc::new(3u32), 40);
        assert!(c.get::<u32>(2).is_none(), "2 was least recently used");
        assert_eq!(c.get::<u32>(1).as_deref(), Some(&1));
        assert_eq!(c.get::<u32>(3).as_deref(), Some(&3));
        let n = c.counters();
        assert_eq!((n.entries, n.bytes, n.evictions), (2, 80, 1));
    }

    #[test]
    fn oversized_values_are_not_stored_and_types_are_checked() {
        let c = ResultCache::new(10);
        c.put(1, Arc::new(1u32), 11);
        assert!(c.get::<u32>(1).is_none());
        c.put(2, Arc::new(2u32), 4);
        assert!(c.get::<String>(2).is_none(), "wrong type is a miss");
        assert_eq!(c.counters().bytes, 4);
        c.put(2, Arc::new(5u32), 6);
        assert_eq!(
            c.counters().bytes,
            6,
            "replacing an entry releases its bytes"
        );
    }

    #[test]
    fn keys_differ_with_any_input_bit() {
        let k = |x: f64| KeyBuilder::new("s").debug(&x).finish();
        assert_ne!(k(0.1), k(f64::from_bits(0.1f64.to_bits() + 1)));
        assert_eq!(k(0.1), k(0.1));
        assert_ne!(
            KeyBuilder::new("a").str("bc").finish(),
            KeyBuilder::new("ab").str("c").finish()
        );
    }
}
