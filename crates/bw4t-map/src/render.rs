//! Maps drawn as SVG.
