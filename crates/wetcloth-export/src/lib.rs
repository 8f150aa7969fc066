//! Writers for wetcloth runs (placeholder until the writers land).
