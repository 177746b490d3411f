//! The points a form is fitted to and judged on ([`FormData`]): the table's nodes where every
//! axis is one of the form's variables, otherwise a uniform grid of [`FIT_GRID_NODES`] per
//! variable with the table interpolated there; only those inside a region's ranges, each with the
//! region's weight; and every `stride`-th of them, for a faster fit ([`FormData::every`]).

use super::form::Form;
use super::region::{Region, variable_range};
use crate::error::{Error, Result};
use crate::fit::FIT_GRID_NODES;
use crate::table::Table;

/// The points a form is fitted and judged on: coordinates in the form's variables and the
/// table's values of the form's channels, both row-major.
#[derive(Debug, Clone)]
pub struct FormData {
    pub variables: Vec<String>,
    pub channels: Vec<String>,
    pub coordinates: Vec<f64>,
    pub values: Vec<f64>,
    /// How the points were chosen, for the report.
    pub description: String,
    /// Whether the points are the table's nodes (every axis a variable of the form); otherwise
    /// they are a uniform grid of [`FIT_GRID_NODES`] per variable, the first fastest.
    pub on_table_nodes: bool,
    /// Per point, its number among the table's nodes or the grid's points: the data keeps only
    /// the points inside the region's ranges ([`Region::contains`]).
    pub index: Vec<usize>,
    /// Per point, its weight ([`Region::weight`]) scaled so that the weights' mean is 1 (all 1
    /// for uniform weights, exactly).
    pub weights: Vec<f64>,
    /// Whether the weights are other than uniform.
    pub weighted: bool,
}

impl FormData {
    pub fn len(&self) -> usize {
        self.coordinates.len() / self.variables.len().max(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub(super) fn point(&self, n: usize) -> &[f64] {
        let d = self.variables.len();
        &self.coordinates[n * d..(n + 1) * d]
    }

    pub(super) fn targets(&self, n: usize) -> &[f64] {
        let c = self.channels.len();
        &self.values[n * c..(n + 1) * c]
    }

    /// The table's nodes where every axis is one of the form's variables; otherwise a uniform
    /// grid of [`FIT_GRID_NODES`] per variable over the table's ranges (`eta` over [0, 1]) with
    /// the table interpolated there, so that an axis whose nodes crowd where the table is steep
    /// (TIR's critical-angle axis) does not weight the fit there.
    pub fn from_table(table: &Table, form: &Form) -> Result<FormData> {
        FormData::from_table_in(table, form, &Region::everywhere())
    }

    /// [`FormData::from_table`] keeping the points inside `region`'s ranges, each weighted by it.
    pub fn from_table_in(table: &Table, form: &Form, region: &Region) -> Result<FormData> {
        let channel_index: Vec<usize> =
            form.channels.iter().map(|c| table.channels.iter().position(|t| t.name == c.name).unwrap_or(0)).collect();
        let d = form.variables.len();
        let mut coordinates = Vec::new();
        let mut values = Vec::new();
        let mut index_of_point = Vec::new();
        let plain = table.axes.iter().all(|a| form.variables.contains(&a.name));
        let description;
        if plain {
            // Axis k of the table is the form's variable order[k].
            let order: Vec<usize> =
                table.axes.iter().map(|a| form.variables.iter().position(|v| *v == a.name).unwrap_or(0)).collect();
            for n in 0..table.node_count() {
                let index = table.node_index(n);
                let position = table.node_position(&index);
                let mut point = vec![0.0; d];
                for (k, &v) in order.iter().enumerate() {
                    point[v] = position[k];
                }
                if !region.contains(&point) {
                    continue;
                }
                index_of_point.push(n);
                coordinates.extend(point);
                let node = table.node(&index);
                values.extend(channel_index.iter().map(|&c| f64::from(node[c])));
            }
            description = format!("the table's {} nodes", table.node_count());
        } else {
            let ranges: Vec<(f64, f64)> = form.variables.iter().map(|v| variable_range(table, v)).collect();
            let n = FIT_GRID_NODES;
            let total = n.pow(d as u32);
            let mut value = vec![0.0; table.channel_count()];
            for k in 0..total {
                let mut rest = k;
                let mut point = vec![0.0; d];
                for (p, &(lo, hi)) in point.iter_mut().zip(&ranges) {
                    *p = lo + (hi - lo) * (rest % n) as f64 / (n - 1) as f64;
                    rest /= n;
                }
                if !region.contains(&point) {
                    continue;
                }
                let get = |name: &str| form.variables.iter().position(|v| v == name).map_or(0.0, |i| point[i]);
                let at =
                    crate::table::derived::point_of(&table.axes, get("mu"), get("alpha"), get("eta"), get("kappa"))
                        .ok_or_else(|| {
                            Error::invalid(
                                "fit table",
                                format!("table `{}` has an axis no lookup addresses", table.name),
                            )
                        })?;
                table.interpolate_into(&at, &mut value).map_err(|e| Error::invalid("fit table", format!("{e:?}")))?;
                index_of_point.push(k);
                coordinates.extend(point);
                values.extend(channel_index.iter().map(|&c| value[c]));
            }
            description = format!(
                "a uniform grid of {n} points per variable ({total} in all) over the table's ranges (eta over [0, 1]), the table interpolated there"
            );
        }
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid("fit table", format!("value {bad} of table `{}` is not finite", table.name)));
        }
        let count = index_of_point.len();
        if count == 0 {
            return Err(Error::invalid(
                "--range",
                format!("no point of the data ({description}) lies in {}", region.describe_ranges()),
            ));
        }
        let description = if region.ranges.is_empty() {
            description
        } else {
            format!("{description}; the {count} of them in {}", region.describe_ranges())
        };
        let mut weights: Vec<f64> = coordinates.chunks_exact(d.max(1)).map(|p| region.weight(p)).collect();
        if region.is_weighted() {
            let total: f64 = weights.iter().sum();
            if !(total > 0.0 && total.is_finite()) {
                return Err(Error::invalid(
                    "--weights",
                    format!(
                        "every point in {} has weight 0 ({})",
                        region.describe_ranges(),
                        region.weights_description
                    ),
                ));
            }
            // A mean of 1 keeps the objective on the scale of the unweighted one.
            let scale = count as f64 / total;
            weights.iter_mut().for_each(|w| *w *= scale);
        }
        Ok(FormData {
            variables: form.variables.clone(),
            channels: form.channels.iter().map(|c| c.name.clone()).collect(),
            coordinates,
            values,
            description,
            on_table_nodes: plain,
            index: index_of_point,
            weights,
            weighted: region.is_weighted(),
        })
    }
}

impl FormData {
    /// Every `stride`-th point along each variable (or axis, on the table's nodes) and each one's
    /// last point, of those the data holds (the region's): a coarser grid over the same domain,
    /// for a faster fit judged on every point. `table` is the table the data was read from. The
    /// weights kept are scaled again to a mean of 1.
    pub fn every(&self, table: &Table, stride: usize) -> FormData {
        let shape: Vec<usize> =
            if self.on_table_nodes { table.shape() } else { vec![FIT_GRID_NODES; self.variables.len()] };
        let (d, c) = (self.variables.len(), self.channels.len());
        let mut kept = FormData {
            coordinates: Vec::new(),
            values: Vec::new(),
            index: Vec::new(),
            weights: Vec::new(),
            ..self.clone()
        };
        for (n, &number) in self.index.iter().enumerate() {
            // The first axis runs fastest, on the table's nodes (Table::node_index) as on the grid.
            let mut rest = number;
            let keep = shape.iter().all(|&count| {
                let i = rest % count;
                rest /= count;
                i % stride == 0 || i + 1 == count
            });
            if keep {
                kept.coordinates.extend_from_slice(&self.coordinates[n * d..(n + 1) * d]);
                kept.values.extend_from_slice(&self.values[n * c..(n + 1) * c]);
                kept.index.push(number);
                kept.weights.push(self.weights[n]);
            }
        }
        if self.weighted {
            let total: f64 = kept.weights.iter().sum();
            if total > 0.0 {
                let scale = kept.weights.len() as f64 / total;
                kept.weights.iter_mut().for_each(|w| *w *= scale);
            }
        }
        kept.description = format!("every {stride}th point along each variable of {}", self.description);
        kept
    }
}
