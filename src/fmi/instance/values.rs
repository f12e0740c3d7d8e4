//! `fmi2Get*`/`fmi2Set*` of variables: checked value references, lengths and phases.

use super::*;

impl<M: FmiModel> Instance<M> {
    fn get_all<T>(
        &mut self,
        kind: Kind,
        vrs: &[u32],
        values: &mut [T],
        get: impl Fn(&mut M, u32) -> Result<T, String>,
    ) -> Outcome {
        Self::same_length("value", vrs.len(), values.len())?;
        self.check_known(kind, vrs)?;
        for (vr, value) in vrs.iter().zip(values.iter_mut()) {
            *value = get(&mut self.model, *vr)
                .map_err(|e| format!("{} (value reference {vr}): {e}", self.var_name(kind, *vr)))?;
        }
        Ok(fmi2OK)
    }

    /// Sets every value or none: if one is refused, the ones already set are restored.
    fn set_all<T: std::fmt::Debug>(
        &mut self,
        kind: Kind,
        vrs: &[u32],
        values: &[T],
        get: impl Fn(&mut M, u32) -> Result<T, String>,
        set: impl Fn(&mut M, u32, &T, Phase) -> Result<(), String>,
    ) -> Outcome {
        Self::same_length("value", vrs.len(), values.len())?;
        self.check_known(kind, vrs)?;
        let phase = self.phase();
        let mut done: Vec<(u32, Option<T>)> = Vec::with_capacity(vrs.len());
        for (&vr, value) in vrs.iter().zip(values) {
            let old = get(&mut self.model, vr).ok();
            if let Err(e) = set(&mut self.model, vr, value, phase) {
                for (vr, old) in done.into_iter().rev() {
                    if let Some(old) = old {
                        let _ = set(&mut self.model, vr, &old, phase);
                    }
                }
                let name = self.var_name(kind, vr);
                return Err(format!("cannot set {name} (value reference {vr}) to {value:?}: {e}; no value was changed").into());
            }
            done.push((vr, old));
        }
        Ok(fmi2OK)
    }

    /// `fmi2GetReal`.
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> fmi2Status {
        self.run(Function::GetReal, |this| {
            this.get_all(Kind::Real, vrs, values, |m, vr| m.get_real(vr))
        })
    }

    /// `fmi2GetInteger`.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> fmi2Status {
        self.run(Function::GetInteger, |this| {
            this.get_all(Kind::Integer, vrs, values, |m, vr| m.get_integer(vr))
        })
    }

    /// `fmi2GetBoolean`.
    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [fmi2Boolean]) -> fmi2Status {
        self.run(Function::GetBoolean, |this| {
            this.get_all(Kind::Boolean, vrs, values, |m, vr| {
                m.get_boolean(vr).map(fmi_bool)
            })
        })
    }

    /// `fmi2GetString`: writes pointers to NUL-terminated strings owned by the instance, valid
    /// until the next `get_string` call or until the instance is freed.
    pub fn get_string(&mut self, vrs: &[u32], values: &mut [*const c_char]) -> fmi2Status {
        self.run(Function::GetString, |this| {
            let mut strings = vec![String::new(); vrs.len()];
            this.get_all(Kind::String, vrs, &mut strings, |m, vr| m.get_string(vr))?;
            this.strings = strings.iter().map(|s| c_string_lossless(s)).collect();
            for (out, s) in values.iter_mut().zip(&this.strings) {
                *out = s.as_ptr();
            }
            Ok(fmi2OK)
        })
    }

    /// `fmi2SetReal`: all or nothing (NaN/Inf are for the model to refuse).
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> fmi2Status {
        self.run(Function::SetReal, |this| {
            this.set_all(
                Kind::Real,
                vrs,
                values,
                |m, vr| m.get_real(vr),
                |m, vr, v, p| m.set_real(vr, *v, p),
            )
        })
    }

    /// `fmi2SetInteger`: all or nothing.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> fmi2Status {
        self.run(Function::SetInteger, |this| {
            this.set_all(
                Kind::Integer,
                vrs,
                values,
                |m, vr| m.get_integer(vr),
                |m, vr, v, p| m.set_integer(vr, *v, p),
            )
        })
    }

    /// `fmi2SetBoolean`: all or nothing; any non-zero value is true.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[fmi2Boolean]) -> fmi2Status {
        let values: Vec<bool> = values.iter().map(|&b| b != fmi2False).collect();
        self.run(Function::SetBoolean, |this| {
            this.set_all(
                Kind::Boolean,
                vrs,
                &values,
                |m, vr| m.get_boolean(vr),
                |m, vr, v, p| m.set_boolean(vr, *v, p),
            )
        })
    }

    /// `fmi2SetString`: all or nothing.
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> fmi2Status {
        let values: Vec<String> = values.iter().map(|s| (*s).to_owned()).collect();
        self.run(Function::SetString, |this| {
            this.set_all(
                Kind::String,
                vrs,
                &values,
                |m, vr| m.get_string(vr),
                |m, vr, v, p| m.set_string(vr, v, p),
            )
        })
    }
}
