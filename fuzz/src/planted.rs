//! A test-only model with a planted bug, to show the harness can fail: its `step` panics
//! when the input is exactly 0.5. The shell catches the panic (the importer gets fmi2Error),
//! and the driver's invariant "no panic inside the FMU" turns it into a fuzzer crash.

use magswarm_fmi::fmi2::{
    Ctx, FmuModel, InstantiateArgs, ModelError, ModelInfo, VarType, Variable,
};

static VARIABLES: [Variable; 2] = [
    Variable::real("u", 0).input().start_real(0.0).unit("1"),
    Variable::real("y", 1).output().unit("1").depends_on(&[0]),
];

static INFO: ModelInfo = ModelInfo {
    model_identifier: "Planted",
    model_name: "Planted",
    description: "a gain with a planted bug",
    version: "0",
    author: "",
    copyright: None,
    license: None,
    generation_tool: "magswarm-fuzz",
    naming_convention: magswarm_fmi::fmi2::NamingConvention::Flat,
    default_experiment: None,
    units: &[magswarm_fmi::fmi2::units::ONE],
    log_categories: &[],
    variables: &VARIABLES,
};

/// `y = 2 u`, except that stepping with `u = 0.5` panics.
#[derive(Clone, Debug)]
pub struct Planted {
    u: f64,
    y: f64,
}

impl FmuModel for Planted {
    fn model_info() -> &'static ModelInfo {
        &INFO
    }
    fn instantiate(_: &mut Ctx<'_>, _: &InstantiateArgs<'_>) -> Result<Self, ModelError> {
        Ok(Planted { u: 0.0, y: 0.0 })
    }
    fn step(&mut self, _: &mut Ctx<'_>, _t: f64, _h: f64) -> Result<(), ModelError> {
        if self.u == 0.5 {
            panic!("planted bug: u = 0.5");
        }
        self.y = 2.0 * self.u;
        Ok(())
    }
    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        match vr {
            0 => Ok(self.u),
            1 => Ok(self.y),
            _ => Err(ModelError::unknown_vr(VarType::Real, vr)),
        }
    }
    fn set_real(&mut self, _: &mut Ctx<'_>, vr: u32, x: f64) -> Result<(), ModelError> {
        match vr {
            0 => self.u = x,
            _ => return Err(ModelError::unknown_vr(VarType::Real, vr)),
        }
        Ok(())
    }
    type State = (f64, f64);
    fn save_state(&self) -> Result<(f64, f64), ModelError> {
        Ok((self.u, self.y))
    }
    fn restore_state(&mut self, (u, y): (f64, f64)) -> Result<(), ModelError> {
        (self.u, self.y) = (u, y);
        Ok(())
    }
}
