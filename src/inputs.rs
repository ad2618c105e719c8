//! TEMPORARY stand-in until the inputs branch merges.
use crate::state::Controls;
#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
pub struct InputSpec {}
#[derive(Debug, Clone, Default)]
pub struct InputSchedule {}
impl InputSchedule {
    pub fn build(
        _specs: &[InputSpec],
        _base: &std::path::Path,
        _p: &std::path::Path,
    ) -> crate::Result<InputSchedule> {
        Ok(InputSchedule {})
    }
    pub fn deviation(&self, _t: f64) -> Controls {
        Controls::zeros()
    }
    pub fn is_empty(&self) -> bool {
        true
    }
}
