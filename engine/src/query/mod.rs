//! Scene-level ray queries.
