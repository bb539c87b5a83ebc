//! A part's summary on disk: the marginals' cells listed only where a pose fell.

use serde::{Deserialize, Serialize};

use super::{Marginal, Summary, mean_of};
use crate::error::{Error, Result};

/// A part's summary as kept on disk: marginal cells listed only where a pose fell.
/// A chunk touches few of a large marginal's cells. The axes' values are left out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartSummary {
    /// The summary, its marginals without cells.
    pub summary: Summary,
    /// Per marginal, the cells with a pose.
    pub cells: Vec<Vec<Cell>>,
}

/// One marginal cell of a part: (cell, count, min, max, exact sum).
pub type Cell = (usize, u64, f64, f64, i128);

impl Summary {
    /// Returns this summary with its marginals' cells listed sparsely, for a part on disk.
    #[must_use]
    pub fn to_part(&self) -> PartSummary {
        let mut cells = Vec::with_capacity(self.marginals.len());
        for m in &self.marginals {
            cells.push(
                (0..m.count.len())
                    .filter(|&c| m.count[c] > 0)
                    .map(|c| {
                        (
                            c,
                            m.count[c],
                            m.min[c].unwrap_or(f64::NAN),
                            m.max[c].unwrap_or(f64::NAN),
                            m.sum[c],
                        )
                    })
                    .collect(),
            );
        }
        // Copy the rest, minus the dense cells: they are as large as the marginal, however
        // small the part.
        let summary = Summary {
            metric: self.metric.clone(),
            poses: self.poses,
            with_value: self.with_value,
            min: self.min,
            max: self.max,
            smallest: self.smallest.clone(),
            largest: self.largest.clone(),
            histogram: self.histogram.clone(),
            marginals: self
                .marginals
                .iter()
                .map(|m| Marginal {
                    axes: m.axes.clone(),
                    values: Vec::new(),
                    count: Vec::new(),
                    min: Vec::new(),
                    mean: Vec::new(),
                    max: Vec::new(),
                    sum: Vec::new(),
                })
                .collect(),
        };
        PartSummary { summary, cells }
    }
}

impl PartSummary {
    /// Returns the summary this part holds, its marginals dense again.
    /// The axis values come from `template`, the sweep's empty summary.
    ///
    /// # Errors
    /// [`Error::Csv`] naming `context` for a cell outside its marginal or a non-integer sum.
    pub fn into_summary(self, template: &Summary, context: &str) -> Result<Summary> {
        let bad = |message: &str| Error::Csv {
            context: context.to_string(),
            message: message.to_string(),
        };
        let mut summary = self.summary;
        if self.cells.len() != summary.marginals.len() {
            return Err(bad("its marginals and their cells differ in number"));
        }
        if template.marginals.len() != summary.marginals.len() {
            return Err(bad("its marginals are not the [summary]'s"));
        }
        for ((m, cells), t) in summary
            .marginals
            .iter_mut()
            .zip(self.cells)
            .zip(&template.marginals)
        {
            m.values.clone_from(&t.values);
            let n = m.values.iter().map(Vec::len).product();
            m.count = vec![0; n];
            m.min = vec![None; n];
            m.mean = vec![None; n];
            m.max = vec![None; n];
            m.sum = vec![0; n];
            for (c, count, min, max, sum) in cells {
                if c >= n || count == 0 {
                    return Err(bad("a marginal's cell is outside it or empty"));
                }
                m.count[c] = count;
                m.min[c] = Some(min);
                m.max[c] = Some(max);
                m.mean[c] = mean_of(sum, count);
                m.sum[c] = sum;
            }
        }
        Ok(summary)
    }
}
