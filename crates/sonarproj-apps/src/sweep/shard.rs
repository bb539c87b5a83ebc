//! Part K of N of a sweep: a contiguous range of pose indices, sizes differing by at most one.
//! Shards run anywhere and merge into the file one run writes.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Part `k` (1-based) of `n` independent parts of a sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which part, 1 to `n`.
    pub k: u64,
    /// How many parts.
    pub n: u64,
}

pub use crate::limits::MAX_SHARDS;

impl Shard {
    /// Returns the shard written `K/N`.
    ///
    /// # Errors
    /// [`sonarproj::Error::InvalidValue`] naming the shard unless `1 <= K <= N`.
    pub fn parse(text: &str) -> Result<Shard> {
        let bad = || {
            Error::invalid(
                crate::params::SHARD,
                format!("{text:?}"),
                "must be K/N with 1 <= K <= N, e.g. 3/8",
            )
        };
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (k, n): (u64, u64) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || k > n {
            return Err(bad());
        }
        if n > MAX_SHARDS {
            return Err(Error::invalid(
                crate::params::SHARD,
                format!("{text:?}"),
                format!("N must be at most {MAX_SHARDS} (merge lists the parts it finds)"),
            ));
        }
        Ok(Shard { k, n })
    }

    /// Returns this shard's contiguous pose indices out of `total`.
    #[expect(
        clippy::cast_possible_truncation,
        reason = "pose counts and chunk sizes are bounded (MAX_POSES) before this point"
    )]
    #[must_use]
    pub fn range(self, total: u64) -> Range<u64> {
        let at = |k: u64| (u128::from(total) * u128::from(k) / u128::from(self.n)) as u64;
        at(self.k - 1)..at(self.k)
    }

    /// Returns the shard's file stem, `shard-K-of-N`.
    #[must_use]
    pub fn stem(self) -> String {
        format!("shard-{}-of-{}", self.k, self.n)
    }
}
