//! Parameter lists: `"type name" value` or `"type name" [ values ]`. The parser checks that
//! the values fit the declared type; statements then ask for parameters by type and name,
//! and the ones never asked for are reported as unsupported.

use std::cell::Cell;

#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    Nums(Vec<f64>),
    Strs(Vec<String>),
    Bools(Vec<bool>),
}

impl Values {
    pub fn kind(&self) -> &'static str {
        match self {
            Values::Nums(_) => "numbers",
            Values::Strs(_) => "strings",
            Values::Bools(_) => "booleans",
        }
    }
}

#[derive(Debug)]
pub struct Param {
    /// The declared type, normalised: `point` is `point3`, `normal` is `normal3`, `vector`
    /// is `vector3`, `color` is `rgb`.
    pub ty: String,
    pub name: String,
    pub values: Values,
    pub line: u32,
    pub col: u32,
    used: Cell<bool>,
}

/// The parameter types pbrt-v4 knows, with the kind of values each takes and how many
/// numbers make one item.
fn type_info(ty: &str) -> Option<(&'static str, &'static str, usize)> {
    Some(match ty {
        "integer" => ("integer", "numbers", 1),
        "float" => ("float", "numbers", 1),
        "point2" => ("point2", "numbers", 2),
        "vector2" => ("vector2", "numbers", 2),
        "point3" | "point" => ("point3", "numbers", 3),
        "vector3" | "vector" => ("vector3", "numbers", 3),
        "normal3" | "normal" => ("normal3", "numbers", 3),
        "rgb" | "color" => ("rgb", "numbers", 3),
        "blackbody" => ("blackbody", "numbers", 1),
        "spectrum" => ("spectrum", "any", 1),
        "bool" => ("bool", "booleans", 1),
        "string" => ("string", "strings", 1),
        "texture" => ("texture", "strings", 1),
        _ => return None,
    })
}

impl Param {
    /// Checks a parsed `"type name"` and its values; the message says what is wrong.
    pub fn new(decl: &str, values: Values, line: u32, col: u32) -> Result<Param, String> {
        let words: Vec<&str> = decl.split_whitespace().collect();
        let [ty, name] = words[..] else {
            return Err(format!(
                "parameter declaration \"{decl}\" must be \"TYPE NAME\", e.g. \"float radius\""
            ));
        };
        let Some((ty, kind, arity)) = type_info(ty) else {
            return Err(format!("unknown parameter type `{ty}` in \"{decl}\""));
        };
        // pbrt accepts "true"/"false" strings for booleans.
        let values = match (kind, values) {
            ("booleans", Values::Strs(s)) if s.iter().all(|v| v == "true" || v == "false") => {
                Values::Bools(s.iter().map(|v| v == "true").collect())
            }
            (_, v) => v,
        };
        if kind != "any" && values.kind() != kind {
            return Err(format!(
                "parameter \"{decl}\" takes {kind}, got {}",
                values.kind()
            ));
        }
        match &values {
            Values::Nums(v) => {
                if ty == "spectrum" && v.len() % 2 != 0 {
                    return Err(format!(
                        "parameter \"{decl}\" takes (wavelength, value) pairs, got {} numbers",
                        v.len()
                    ));
                }
                if v.len() % arity != 0 || v.is_empty() {
                    return Err(format!(
                        "parameter \"{decl}\" takes a multiple of {arity} numbers, got {}",
                        v.len()
                    ));
                }
                if ty == "integer" {
                    if let Some(x) = v.iter().find(|x| x.fract() != 0.0 || x.abs() > 2e9) {
                        return Err(format!("parameter \"{decl}\" takes integers, got {x}"));
                    }
                }
            }
            Values::Strs(v) if v.is_empty() => {
                return Err(format!("parameter \"{decl}\" has no value"))
            }
            Values::Bools(v) if v.is_empty() => {
                return Err(format!("parameter \"{decl}\" has no value"))
            }
            _ => {}
        }
        if ty == "spectrum" && matches!(values, Values::Bools(_)) {
            return Err(format!(
                "parameter \"{decl}\" takes numbers or a string, got booleans"
            ));
        }
        Ok(Param {
            ty: ty.to_string(),
            name: name.to_string(),
            values,
            line,
            col,
            used: Cell::new(false),
        })
    }

    pub fn nums(&self) -> &[f64] {
        match &self.values {
            Values::Nums(v) => v,
            _ => &[],
        }
    }

    pub fn strs(&self) -> &[String] {
        match &self.values {
            Values::Strs(v) => v,
            _ => &[],
        }
    }
}

/// The parameters of one statement.
#[derive(Debug, Default)]
pub struct Params {
    pub list: Vec<Param>,
}

/// A parameter problem: its position and message.
pub struct ParamError {
    pub line: u32,
    pub col: u32,
    pub msg: String,
}

pub type PResult<T> = Result<T, ParamError>;

impl Params {
    /// The parameter called `name` if its type is one of `types`; an error if a parameter
    /// of that name has another type. Marks it as used.
    pub fn find(&self, name: &str, types: &[&str]) -> PResult<Option<&Param>> {
        let Some(p) = self.list.iter().rev().find(|p| p.name == name) else {
            return Ok(None);
        };
        p.used.set(true);
        if types.contains(&p.ty.as_str()) {
            Ok(Some(p))
        } else {
            Err(ParamError {
                line: p.line,
                col: p.col,
                msg: format!(
                    "parameter `{name}` must be of type {}, got {}",
                    types.join(" or "),
                    p.ty
                ),
            })
        }
    }

    fn one(&self, name: &str, ty: &str) -> PResult<Option<&Param>> {
        let p = self.find(name, &[ty])?;
        if let Some(p) = p {
            let n = match &p.values {
                Values::Nums(v) => v.len(),
                Values::Strs(v) => v.len(),
                Values::Bools(v) => v.len(),
            };
            let arity = type_info(ty).map_or(1, |t| t.2);
            if n != arity {
                return Err(p.error(format!(
                    "parameter `{name}` takes one {ty} value, got {}",
                    n / arity.max(1)
                )));
            }
        }
        Ok(p)
    }

    pub fn float(&self, name: &str) -> PResult<Option<f64>> {
        Ok(self.one(name, "float")?.map(|p| p.nums()[0]))
    }

    pub fn float_or(&self, name: &str, default: f64) -> PResult<f64> {
        Ok(self.float(name)?.unwrap_or(default))
    }

    pub fn int(&self, name: &str) -> PResult<Option<i64>> {
        Ok(self.one(name, "integer")?.map(|p| p.nums()[0] as i64))
    }

    pub fn bool(&self, name: &str) -> PResult<Option<bool>> {
        Ok(self.one(name, "bool")?.map(|p| match &p.values {
            Values::Bools(b) => b[0],
            _ => false,
        }))
    }

    pub fn string(&self, name: &str) -> PResult<Option<String>> {
        Ok(self.one(name, "string")?.map(|p| p.strs()[0].clone()))
    }

    pub fn strings(&self, name: &str) -> PResult<Option<Vec<String>>> {
        Ok(self.find(name, &["string"])?.map(|p| p.strs().to_vec()))
    }

    pub fn floats(&self, name: &str, ty: &str) -> PResult<Option<&[f64]>> {
        Ok(self.find(name, &[ty])?.map(Param::nums))
    }

    pub fn ints(&self, name: &str) -> PResult<Option<Vec<i64>>> {
        Ok(self
            .find(name, &["integer"])?
            .map(|p| p.nums().iter().map(|&x| x as i64).collect()))
    }

    /// Marks a parameter as handled without reading it (it is accepted and ignored).
    pub fn ignore(&self, name: &str) {
        for p in &self.list {
            if p.name == name {
                p.used.set(true);
            }
        }
    }

    /// The parameters no statement asked for.
    pub fn unused(&self) -> impl Iterator<Item = &Param> {
        self.list.iter().filter(|p| !p.used.get())
    }
}

impl Param {
    pub fn error(&self, msg: impl Into<String>) -> ParamError {
        ParamError {
            line: self.line,
            col: self.col,
            msg: msg.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nums(v: &[f64]) -> Values {
        Values::Nums(v.to_vec())
    }

    #[test]
    fn declarations_are_checked_against_values() {
        assert!(Param::new("float fov", nums(&[45.0]), 1, 1).is_ok());
        let p = Param::new("point P", nums(&[0.0; 6]), 1, 1).unwrap();
        assert_eq!(p.ty, "point3");
        let e = |d: &str, v: Values| Param::new(d, v, 1, 1).unwrap_err();
        assert!(e("float fov", Values::Strs(vec!["x".into()])).contains("takes numbers"));
        assert!(e("point3 P", nums(&[1.0, 2.0])).contains("multiple of 3"));
        assert!(e("integer n", nums(&[1.5])).contains("integers"));
        assert!(e("quaternion q", nums(&[1.0])).contains("unknown parameter type"));
        assert!(e("fov", nums(&[1.0])).contains("TYPE NAME"));
        assert!(e("spectrum s", nums(&[400.0])).contains("pairs"));
        let b = Param::new("bool twosided", Values::Strs(vec!["true".into()]), 1, 1).unwrap();
        assert_eq!(b.values, Values::Bools(vec![true]));
    }

    #[test]
    fn lookups_check_types_and_track_use() {
        let params = Params {
            list: vec![
                Param::new("float fov", nums(&[30.0]), 3, 5).unwrap(),
                Param::new("string filename", Values::Strs(vec!["a.exr".into()]), 4, 5).unwrap(),
                Param::new("float lensradius", nums(&[0.1]), 5, 5).unwrap(),
            ],
        };
        assert_eq!(params.float("fov").ok().flatten(), Some(30.0));
        assert_eq!(params.float("missing").ok().flatten(), None);
        let e = params.float("filename").err().unwrap();
        assert_eq!(e.line, 4);
        assert!(
            e.msg.contains("must be of type float, got string"),
            "{}",
            e.msg
        );
        let unused: Vec<&str> = params.unused().map(|p| p.name.as_str()).collect();
        assert_eq!(unused, ["lensradius"]);
    }
}
