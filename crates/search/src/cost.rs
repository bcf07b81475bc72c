//! One objective as an argmin cost function to minimise (design §4.3): cost = −Φ for a maximum,
//! +Φ for a minimum, +∞ at an infeasible point. `bulk_cost` sends a whole generation (or poll
//! set) to the session as one batch; a refused batch surfaces as a [`Stop`] error.
//!
//! [`Stop`]: super::session::Stop

use super::session::Session;
use argmin::core::{CostFunction, Error, SendAlias, SyncAlias};
use std::borrow::Borrow;

pub(super) struct ObjectiveCost<'s, 'a> {
    pub(super) session: &'s Session<'a>,
    pub(super) objective: usize,
}

impl CostFunction for ObjectiveCost<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, param: &Vec<f64>) -> Result<f64, Error> {
        self.bulk_cost(std::slice::from_ref(param))?
            .pop()
            .ok_or_else(|| Error::msg("no cost for the point"))
    }

    fn bulk_cost<P>(&self, params: &[P]) -> Result<Vec<f64>, Error>
    where
        P: Borrow<Vec<f64>> + SyncAlias,
        f64: SendAlias,
        Self: SyncAlias,
    {
        let units: Vec<&[f64]> = params.iter().map(|p| p.borrow().as_slice()).collect();
        let sense = self.session.objectives()[self.objective].sense;
        Ok(self
            .session
            .values(&units, self.objective)?
            .into_iter()
            .map(|v| v.map_or(f64::INFINITY, |v| -sense.score(v)))
            .collect())
    }
}
