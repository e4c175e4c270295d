//! The NetCDF format's reader in the registry: its arrays (`Reader`, with CF's volumes, grid
//! axes and the grid's further variables) and its variables with named dimensions
//! (`Variables`, the model the CF conventions read), both over the functions of `netcdf`.

use std::path::Path;

use super::{
    auxiliary_names, coordinate_variable, global_attributes, list_variables, open,
    read_variable_window, rolled_by, variable_attributes, Dims, NcAttribute, NcVariable,
};
use crate::error::{Error, Result};

/// The NetCDF reader (classic and NetCDF-4): variables with their dimensions, read under a
/// selection and CF-decoded, volumes and grids placed by their CF coordinates.
pub(crate) struct NetcdfReader;

impl crate::datasets::readers::Reader for NetcdfReader {
    fn list(&self, path: &Path) -> Result<Vec<crate::datasets::ArrayListing>> {
        let file = open(path)?;
        let vars = file
            .variables()
            .map_err(|e| Error::format(path, e.to_string()))?;
        let auxiliary = auxiliary_names(vars);
        Ok(vars
            .iter()
            .map(|v| crate::datasets::ArrayListing {
                name: v.name().to_string(),
                shape: v.shape().iter().map(|&s| s as usize).collect(),
                dtype: format!("{:?}", v.dtype()).to_lowercase(),
                is_coordinate: v.is_coordinate_variable(),
                is_auxiliary: auxiliary.iter().any(|a| a == v.name()),
                unreadable: None,
            })
            .collect())
    }

    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        rank: Option<usize>,
        sel: &crate::datasets::select::Selection,
    ) -> Result<crate::datasets::ArrayData> {
        crate::datasets::read_netcdf_array(path, var, rank, sel)
    }

    /// The other data variables of the grid's shape, and a saved section's per-column latitude
    /// and longitude.
    fn grid_extras(
        &self,
        path: &Path,
        ask: &crate::datasets::readers::ExtrasAsked,
    ) -> Result<crate::datasets::readers::GridExtras> {
        let mut extras = crate::datasets::same_shape_arrays(path, ask)?;
        if !ask.x_is_longitude {
            let present: Vec<String> = std::iter::once(ask.main.to_string())
                .chain(extras.properties.iter().map(|p| p.0.clone()))
                .collect();
            let columns =
                crate::datasets::grid_out::column_properties(path, ask.coord_names[0], ask.shape)?;
            extras
                .properties
                .extend(columns.into_iter().filter(|c| !present.contains(&c.0)));
        }
        Ok(extras)
    }

    fn variables(&self) -> Option<&dyn crate::datasets::readers::variables::Variables> {
        Some(self)
    }
}

impl crate::datasets::readers::variables::Variables for NetcdfReader {
    fn list(&self, path: &Path) -> Result<Vec<(String, Dims)>> {
        list_variables(path)
    }

    fn attributes(&self, path: &Path, name: &str) -> Result<Vec<(String, NcAttribute)>> {
        variable_attributes(path, name)
    }

    fn global_attributes(&self, path: &Path) -> Result<Vec<(String, NcAttribute)>> {
        global_attributes(path)
    }

    fn read(
        &self,
        path: &Path,
        name: &str,
        picks: &[Option<usize>],
        window: Option<(usize, std::ops::Range<usize>)>,
    ) -> Result<NcVariable> {
        read_variable_window(path, name, picks, window)
    }

    fn coordinate(&self, path: &Path, dim: &str) -> Result<Option<NcVariable>> {
        coordinate_variable(path, dim)
    }

    fn rolled_by(&self, path: &Path, dim: &str) -> Result<Option<usize>> {
        rolled_by(path, dim)
    }

    fn integers(
        &self,
        path: &Path,
        name: &str,
    ) -> Result<Option<crate::datasets::readers::variables::Integers>> {
        super::read_integers(path, name)
    }
}
