//! Script API: arithmetic on fields ([`crate::model::arithmetic`]) — `+ - * /` between grids,
//! between volumes and with a number on either side; `mean`, `min`, `max` and `std` over an
//! array of grids or of volumes; `with_units` to say what a result is in.

use super::api_render::ScriptVolume;
use super::api_surface::ScriptGrid;
use super::convert::{err, to_rhai, RResult};
use crate::model::arithmetic::{self, Op, Reduction, Side};
use rhai::{Array, Dynamic, Engine, FLOAT, INT};
use std::sync::Arc;

pub(crate) fn register(engine: &mut Engine) {
    for op in [Op::Add, Op::Sub, Op::Mul, Op::Div] {
        register_op(engine, op);
    }
    for how in [
        Reduction::Mean,
        Reduction::Min,
        Reduction::Max,
        Reduction::Std,
    ] {
        engine.register_fn(how.name(), move |fields: Array| reduce(&fields, how));
    }
    engine.register_fn(
        "with_units",
        |g: ScriptGrid, units: &str| -> RResult<ScriptGrid> {
            Ok(Arc::new(
                arithmetic::grid_with_units(&g, units).map_err(to_rhai)?,
            ))
        },
    );
    engine.register_fn(
        "with_units",
        |v: ScriptVolume, units: &str| -> ScriptVolume {
            let mut out = (*v).clone();
            out.units = units.to_string();
            Arc::new(out)
        },
    );
}

/// `op` between grids, between volumes, and with a number (float or integer) on either side.
fn register_op(engine: &mut Engine, op: Op) {
    let sym = op.symbol();
    let grid = move |g: &ScriptGrid, x: f64, side: Side| -> RResult<ScriptGrid> {
        Ok(Arc::new(
            arithmetic::grid_number(g, op, x, side).map_err(to_rhai)?,
        ))
    };
    let volume = move |v: &ScriptVolume, x: f64, side: Side| -> RResult<ScriptVolume> {
        Ok(Arc::new(
            arithmetic::volume_number(v, op, x, side).map_err(to_rhai)?,
        ))
    };
    engine.register_fn(
        sym,
        move |a: ScriptGrid, b: ScriptGrid| -> RResult<ScriptGrid> {
            Ok(Arc::new(arithmetic::grids(&a, op, &b).map_err(to_rhai)?))
        },
    );
    engine.register_fn(sym, move |a: ScriptGrid, x: FLOAT| grid(&a, x, Side::Right));
    engine.register_fn(sym, move |a: ScriptGrid, x: INT| {
        grid(&a, x as f64, Side::Right)
    });
    engine.register_fn(sym, move |x: FLOAT, a: ScriptGrid| grid(&a, x, Side::Left));
    engine.register_fn(sym, move |x: INT, a: ScriptGrid| {
        grid(&a, x as f64, Side::Left)
    });
    engine.register_fn(
        sym,
        move |a: ScriptVolume, b: ScriptVolume| -> RResult<ScriptVolume> {
            Ok(Arc::new(arithmetic::volumes(&a, op, &b).map_err(to_rhai)?))
        },
    );
    engine.register_fn(sym, move |a: ScriptVolume, x: FLOAT| {
        volume(&a, x, Side::Right)
    });
    engine.register_fn(sym, move |a: ScriptVolume, x: INT| {
        volume(&a, x as f64, Side::Right)
    });
    engine.register_fn(sym, move |x: FLOAT, a: ScriptVolume| {
        volume(&a, x, Side::Left)
    });
    engine.register_fn(sym, move |x: INT, a: ScriptVolume| {
        volume(&a, x as f64, Side::Left)
    });
}

/// `how` over an array of grids (a grid) or of volumes (a volume).
fn reduce(fields: &Array, how: Reduction) -> RResult<Dynamic> {
    let grids: Option<Vec<ScriptGrid>> = fields
        .iter()
        .map(|f| f.clone().try_cast::<ScriptGrid>())
        .collect();
    if let Some(grids) = grids.filter(|g| !g.is_empty()) {
        let refs: Vec<&crate::model::Grid> = grids.iter().map(|g| g.as_ref()).collect();
        let out = arithmetic::reduce_grids(&refs, how).map_err(to_rhai)?;
        return Ok(Dynamic::from(Arc::new(out) as ScriptGrid));
    }
    let volumes: Option<Vec<ScriptVolume>> = fields
        .iter()
        .map(|f| f.clone().try_cast::<ScriptVolume>())
        .collect();
    if let Some(volumes) = volumes.filter(|v| !v.is_empty()) {
        let refs: Vec<&crate::model::Volume> = volumes.iter().map(|v| v.as_ref()).collect();
        let out = arithmetic::reduce_volumes(&refs, how).map_err(to_rhai)?;
        return Ok(Dynamic::from(Arc::new(out) as ScriptVolume));
    }
    err(
        how.name(),
        format!(
            "expected a non-empty array of grids or of volumes, got {} items",
            fields.len()
        ),
    )
}
