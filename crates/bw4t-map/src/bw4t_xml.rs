//! Original BW4T map files (JAXB XML, root `<newMap>`).

use crate::model::Map;

/// Why an original BW4T map file could not be loaded.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct XmlError(pub String);

impl Map {
    /// Parses an original BW4T XML map.
    pub fn from_bw4t_xml(_text: &str) -> Result<Map, XmlError> {
        Err(XmlError("not implemented yet".into()))
    }
}
