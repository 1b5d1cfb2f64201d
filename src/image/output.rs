//! Writing render results: format by extension, tone mapping for 8-bit formats, atomic writes.
