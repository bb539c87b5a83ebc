//! CSV files in and out: projection batches (`batch`) and correspondences to recover
//! (`recover`), both read through one checked table reader (`table`).

pub mod batch;
pub mod recover;
pub mod table;

pub use batch::{BatchInput, METRIC_COLUMNS, metric_fields, read_batch_csv, write_batch_csv};

/// Returns `v` in its shortest exact form, or an empty field for `None`.
pub fn field(v: Option<f64>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}
