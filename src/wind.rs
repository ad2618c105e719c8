//! TEMPORARY stand-in until the wind branch merges.
use nalgebra::Vector3;
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WindSample {
    pub ned: Vector3<f64>,
    pub body: Vector3<f64>,
}
#[derive(Debug, Clone, Default, serde::Deserialize, serde::Serialize)]
pub struct WindSpec {}
pub struct FlightConditions {
    pub airspeed: f64,
    pub altitude: f64,
}
impl WindSpec {
    pub fn validate(&self, _p: &mut crate::error::Problems) {}
    pub fn generate(
        &self,
        _c: &FlightConditions,
        _s: f64,
        count: usize,
        _seed: u64,
    ) -> Result<Vec<WindSample>, String> {
        Ok(vec![WindSample::default(); count])
    }
}
