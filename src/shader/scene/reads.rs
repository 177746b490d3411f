//! How a material's function reads the folder's tables: the scene shader's [`Reader`] of
//! [`Routes`], and the read each [`LookupSource`] prints, as [`crate::model::folder::FolderTables`]
//! samples it on the CPU. The coordinates are printed from the CPU's own code
//! ([`Axis::texture_coordinate_in`], [`point_in`], [`slice_choice_distance_in`]) through
//! [`InShader`], an [`Arithmetic`] of shader expressions.
//!
//! Tables are read by texel loads filtered in the shader (four or eight `textureLoad`s and lerps
//! in f32: [`crate::filter`]'s filter, printed by [`super::helpers`]), not by the
//! sampler: hardware filtering weighs texels with 8 fractional bits on most GPUs, which alone
//! moves a value by up to 1/512 of a texel step, and float32 textures are not filterable in
//! WebGPU without a feature.
//! Every lookup the plan can choose is read: albedo from FGD slices, the lossless FGD packing, or
//! the Belcour and Karis split-sum tables with their Fresnel coefficients folded to constants; TIR
//! from slices, the 3D TIR table (its third axis `eta` or the critical-angle offset), the fitted
//! form, or off; GD from its 2D table.

use super::super::{Builtin, Expr, Ty, call, float, func, name, select};
use super::choosers::{Candidate, Chooser};
use super::{Generator, ShaderMaterial};
use crate::error::{Error, Result};
use crate::fit::forms::fitted::{FittedForm, FittedFormExt};
use crate::formats::FileFormat;
use crate::formats::manifest::{FileEntry, FitEntry};
use crate::loader::{ArrayPlace, FolderSlice, LutFolder, TextureBinding};
use crate::model::folder::{slice_choice_distance, slice_choice_distance_in};
use crate::model::routes::{LookupSource, Paths, Reader, Routes};
use crate::model::{AlbedoPath, Quantity};
use crate::packing::PackedFgd;
use crate::physics::normal_incidence_reflectance;
use crate::table::derived::{self, point_in};
use crate::table::{Arithmetic, Axis, TableKind};

/// A table file the shader reads: its axes and channels as stored, and where it lies.
#[derive(Debug, Clone)]
pub(super) struct TableFile {
    file: String,
    /// The table's name: a texture array holds several.
    table: String,
    /// Where a slice of a texture array lies in it.
    place: Option<ArrayPlace>,
    axes: Vec<Axis>,
    channels: usize,
}

impl TableFile {
    fn of(file: &str, entry: &FileEntry, place: Option<ArrayPlace>) -> Self {
        TableFile {
            file: file.to_string(),
            table: entry.table.clone(),
            place,
            axes: entry.axes.iter().map(|a| a.axis.clone()).collect(),
            channels: padded(entry.channels.len()),
        }
    }
}

/// The scene shader's [`Reader`]: of each file, what its reads print. It binds textures only (a
/// `.bin` table is no texture), and reads the 4D FGD table through its lossless packing.
pub(super) struct Printing;

impl Reader for Printing {
    type Table = TableFile;
    type FullFgd = (String, PackedFgd);
    type Form = FittedForm;
    const FORMATS: &'static [FileFormat] = &FileFormat::TEXTURES;
    const FULL_FGD: &'static str = "lossless FGD packing (the shader reads the 4D table through it)";

    fn slice(&self, slice: FolderSlice) -> Result<TableFile> {
        Ok(TableFile::of(&slice.file, &slice.entry, slice.place))
    }

    fn table(&self, _: &LutFolder, file: &str, entry: &FileEntry) -> Result<TableFile> {
        Ok(TableFile::of(file, entry, None))
    }

    fn full_fgd(
        &self,
        folder: &LutFolder,
        packing: Option<(&str, &FileEntry)>,
        _: Option<(&str, &FileEntry)>,
    ) -> Result<Option<(String, PackedFgd)>> {
        packing
            .map(|(file, entry)| Ok((file.to_string(), crate::model::folder::packed_fgd(folder, file, entry)?)))
            .transpose()
    }

    fn fit(&self, _: &LutFolder, fit: &FitEntry) -> Result<Option<FittedForm>> {
        Ok(FittedForm::of_build(fit))
    }
}

/// How material `m` reads its tables.
pub(super) fn paths(m: &ShaderMaterial) -> Paths {
    Paths { albedo: m.albedo, albedo_form: m.albedo_form.is_some(), tir: m.tir }
}

impl Generator<'_> {
    /// The texture variable of `file`, binding it on first use.
    fn bind(&mut self, file: &str, extent: [usize; 3], dimension: u8, channels: usize, layered: bool) -> String {
        let binding = match self.used.get(file) {
            Some(&binding) => binding,
            None => self.bind_new(file, extent, dimension, channels, layered),
        };
        self.reading.insert(binding);
        let readers = &mut self.readers[binding as usize];
        if !readers.lookups.contains(&self.lookup) {
            readers.lookups.push(self.lookup.clone());
        }
        self.textures[binding as usize].variable.clone()
    }

    /// The next binding, for `file`.
    fn bind_new(&mut self, file: &str, extent: [usize; 3], dimension: u8, channels: usize, layered: bool) -> u32 {
        let binding = self.textures.len() as u32;
        self.textures.push(TextureBinding {
            binding,
            variable: format!("tmh_table{binding}"),
            file: file.to_string(),
            extent,
            dimension,
            depth: if dimension == 3 { extent[2] } else { 1 },
            array_layers: if layered { extent[2] } else { 1 },
            channels,
            layered,
            format: String::new(),
            view_dimension: match (layered, dimension) {
                (true, _) => "2d-array",
                (false, 3) => "3d",
                _ => "2d",
            }
            .into(),
            sample_type: "unfilterable-float".into(),
        });
        let slice_file = self.lookup_reads_slices && !layered;
        self.readers.push(super::BindingReaders { lookups: Vec::new(), slice_file });
        self.used.insert(file.to_string(), binding);
        binding
    }

    /// The texture variable of a table of two or three axes, one texel per node.
    fn bind_table(&mut self, t: &TableFile) -> String {
        let count = |d: usize| t.axes.get(d).map_or(1, |a| a.count);
        if t.axes.iter().any(|a| a.mapping.asinh_parts().is_some()) {
            self.needs.asinh = true;
        }
        match t.place {
            Some(place) => {
                let [width, height] = place.layer_extent.map(|e| e as usize);
                self.bind(&t.file, [width, height, place.layers as usize], 2, t.channels, true)
            }
            None => self.bind(&t.file, [count(0), count(1), count(2)], t.axes.len() as u8, t.channels, false),
        }
    }

    /// Every channel of 2D table `t` at `(mu, alpha)`: the manifest's texture coordinate of each
    /// axis in f32, then bilinear filtering by hand (a `vec4`).
    fn read2(&mut self, t: &TableFile, mu: Expr, alpha: Expr) -> Expr {
        let variable = self.bind_table(t);
        if let Some(place) = t.place {
            // A slice of a texture array: its coordinates clamped to its nodes, in the array
            // (`formats::slice_array::texture_coordinate`), and its layer.
            self.needs.layers = true;
            let [u, v] = [0, 1].map(|d| {
                let x = if d == 0 { mu.clone() } else { alpha.clone() };
                array_coordinate(&t.axes[d], place.origin[d], place.layer_extent[d], x)
            });
            let [width, height] = place.layer_extent.map(|e| float(e as f32));
            let layer = Expr::Construct(Ty::I32, vec![float(place.layer as f32)]);
            return func("tmh_bilinear_layer", vec![name(&variable), u, v, width, height, layer]);
        }
        let [u, v] = [0, 1].map(|d| coordinate(&t.axes[d], if d == 0 { mu.clone() } else { alpha.clone() }));
        func("tmh_bilinear", vec![name(&variable), u, v, float(t.axes[0].count as f32), float(t.axes[1].count as f32)])
    }

    /// The value of the slice among `candidates` (a lookup's [`LookupSource::Slices`]) that
    /// [`crate::model::folder::FolderTables`] chooses: the one with the least
    /// [`slice_choice_distance`] (-1 where its `(mu, alpha)` range holds the lookup, else the sum
    /// over both axes of the distance outside the range, in units of the range, less the slack),
    /// the first of equals: the first that holds it, else the nearest.
    ///
    /// One candidate is read directly, unless slices are read through choosers alone
    /// ([`super::choosers`]). Where several are, the ones that can never be chosen are dropped
    /// when `alpha` is known here (a slice whose alpha range misses it by more than the slack loses
    /// to one that holds it and every `mu`, and so does any slice after that one); the rest are
    /// compared in a function of their own, `tmh_slice<N>(mu, alpha)`.
    fn slice(&mut self, candidates: Vec<(&TableFile, usize)>, mu: Expr, alpha: Expr, known_alpha: Option<f64>) -> Expr {
        let candidates = match known_alpha {
            Some(alpha) => {
                // Holds alpha as the chooser compares it, in f32 (the lattice's ends are exact in f32).
                let holds_alpha = |axis: &Axis| {
                    let (lo, hi) = axis.bounds();
                    lo as f32 <= alpha as f32 && alpha as f32 <= hi as f32
                };
                let always_chosen = candidates.iter().position(|(t, _)| {
                    let (lo, hi) = t.axes[0].bounds();
                    holds_alpha(&t.axes[1]) && lo <= 0.0 && hi >= 1.0
                });
                match always_chosen {
                    Some(k) => candidates
                        .into_iter()
                        .take(k + 1)
                        .enumerate()
                        .filter(|(i, (t, _))| *i == k || slice_choice_distance(&t.axes[1..2], &[alpha]) <= 0.0)
                        .map(|(_, c)| c)
                        .collect(),
                    None => candidates,
                }
            }
            None => candidates,
        };
        match &candidates[..] {
            [(t, c)] if !self.slices_through_choosers => self.read2(t, mu, alpha).member(CHANNELS[*c]),
            _ => func(&self.slice_chooser(&candidates), vec![mu, alpha]),
        }
    }

    /// The function choosing among slice `candidates` at `(mu, alpha)` as [`Self::slice`] says.
    fn slice_chooser(&mut self, candidates: &[(&TableFile, usize)]) -> String {
        let key = candidates.iter().map(|(t, c)| format!("{}/{}#{c}", t.file, t.table)).collect::<Vec<_>>().join(",");
        if let Some(function) = self.choosers.get(&key).cloned() {
            for (t, _) in candidates {
                self.bind_table(t);
            }
            return function;
        }
        let function = format!("tmh_slice{}", self.choosers.len());
        let candidates = candidates
            .iter()
            .map(|(t, c)| Candidate {
                // `slice_choice_distance` in f32: -1 where the range holds (mu, alpha), so that such a
                // slice beats one the lookup merely lies within the slack of.
                distance: slice_choice_distance_in(&t.axes[..2], &[InShader(name("mu")), InShader(name("alpha"))]).0,
                value: self.read2(t, name("mu"), name("alpha")).member(CHANNELS[*c]),
            })
            .collect();
        self.slice_choosers.push(Chooser { name: function.clone(), candidates });
        self.choosers.insert(key, function.clone());
        function
    }

    /// The shader function of a form a material names, printed once in the module whoever calls
    /// it; `read` says what it answers.
    fn form_function(&mut self, fitted: &FittedForm, read: &'static str) -> String {
        if !self.forms.contains(fitted) {
            self.forms.push(fitted.clone());
        }
        self.reads.insert(read.into());
        format!("tmlut_{}", fitted.name)
    }

    /// The value of a lookup of `quantity` by material `m` at `(mu, alpha)` (`known_alpha` where
    /// its roughness is the stack's, not the view's) and relative index `(eta, kappa)`: the read
    /// of what the folder's routes say answers it ([`Routes::answer`]), as the CPU evaluator
    /// samples it.
    pub(super) fn read(
        &mut self,
        m: &ShaderMaterial,
        quantity: Quantity,
        (mu, alpha): (Expr, Expr),
        known_alpha: Option<f64>,
        (eta, kappa): (f64, f64),
    ) -> Result<Expr> {
        let routes = self.routes;
        self.lookup = format!("{} of `{}`", quantity_name(quantity), m.name);
        let source = routes.answer(paths(m), quantity, eta, kappa);
        self.lookup_reads_slices = matches!(source, LookupSource::Slices(_));
        Ok(match source {
            LookupSource::Slices(candidates) => {
                self.reads.insert(format!("{} slice", if quantity == Quantity::Tir { "tir" } else { "fgd" }));
                self.slice(candidates, mu, alpha, known_alpha)
            }
            LookupSource::Table(kind, t) => {
                let what = if kind == TableKind::Gd { "gd".into() } else { format!("{} table", kind.name()) };
                self.table(t, (mu, alpha), (eta, kappa), what)
            }
            LookupSource::SplitSum(kind, t, coefficients) => {
                self.reads.insert(kind.name().into());
                let c = Expr::Construct(Ty::Vec(4), coefficients.iter().map(|&c| float(c as f32)).collect());
                call(Builtin::Dot, vec![c, self.read2(t, mu, alpha)])
            }
            LookupSource::FullFgd((file, packed)) => {
                let extent = [packed.texture.width, packed.texture.height, packed.texture.depth];
                let variable = self.bind(file, extent, 3, 1, false);
                self.packing = Some(packed);
                self.reads.insert("fgd packing".into());
                func(packed.program.name(), vec![name(&variable), mu, alpha, float(eta as f32), float(kappa as f32)])
            }
            LookupSource::FolderForm(fitted) => {
                self.folder_form = Some(fitted);
                self.reads.insert("tir fit".into());
                func("tmlut_tir", vec![mu, alpha, float(eta as f32)])
            }
            LookupSource::MaterialForm => match (quantity, &m.albedo_form, &m.tir_form) {
                (Quantity::Albedo, Some(fitted), _) => {
                    let function = self.form_function(fitted, "albedo form");
                    match m.albedo {
                        // FGD ~ F0 scale + bias, as the Karis table is read.
                        AlbedoPath::Karis => {
                            let f0 = normal_incidence_reflectance(eta, kappa);
                            let weights = Expr::Construct(Ty::Vec(2), vec![float(f0 as f32), float(1.0)]);
                            call(Builtin::Dot, vec![weights, func(&function, vec![mu, alpha])])
                        }
                        // A form of the lookup's own variables: the scene parser sets the FGD path
                        // for a form fitted to `fgd`, and no form reads on the Belcour path.
                        AlbedoPath::Fgd | AlbedoPath::Belcour => {
                            func(&function, vec![mu, alpha, float(eta as f32), float(kappa as f32)])
                        }
                    }
                }
                (Quantity::Tir, _, Some(fitted)) => {
                    let function = self.form_function(fitted, "tir form");
                    func(&function, vec![mu, alpha, float(eta as f32)])
                }
                _ => {
                    return Err(self.refuse(&m.name, "names a TIR form (tir = \"fit:PATH\") and none was given".into()));
                }
            },
            LookupSource::Zero => float(0.0),
            LookupSource::Missing => return Err(self.missing(m, quantity, eta, kappa)),
        })
    }

    /// The error of a lookup the folder holds nothing for.
    fn missing(&self, m: &ShaderMaterial, quantity: Quantity, eta: f64, kappa: f64) -> Error {
        let lacks = Routes::<Printing>::missing(paths(m), quantity, eta, kappa);
        Error::format(&self.manifest_path, format!("lists {lacks}, which material `{}` reads", m.name))
    }

    /// Channel 0 of a table of two or three axes (GD, the 3D TIR table, a stand-in such as FGD
    /// onto a rarer medium) at the point the CPU computes ([`crate::table::derived::point_in`],
    /// printed): each axis's quantity by name, the critical-angle offset or fraction with
    /// `asin(eta)` folded to a constant and `acos` by [`helpers::acos`], not the builtin, whose
    /// error Vulkan bounds only loosely and which the axes' asinh spacing magnifies up to a
    /// thousandfold near the critical angle.
    fn table(&mut self, t: &TableFile, (mu, alpha): (Expr, Expr), (eta, kappa): (f64, f64), what: String) -> Expr {
        let point = point_in(&t.axes, InShader(mu), InShader(alpha), eta, kappa)
            .expect("a table's axes are checked when the folder is opened (Routes::open)");
        self.reads.insert(what);
        if let [u, v] = &point[..] {
            return self.read2(t, u.0.clone(), v.0.clone()).member("x");
        }
        self.needs.acos |= t.axes.iter().any(|axis| derived::definition(&axis.name).is_some());
        let variable = self.bind_table(t);
        self.needs.trilinear = true;
        let mut arguments = vec![name(&variable)];
        arguments.extend(t.axes.iter().zip(point).map(|(axis, x)| coordinate(axis, x.0)));
        arguments.extend(t.axes.iter().map(|axis| float(axis.count as f32)));
        func("tmh_trilinear", arguments)
    }
}

const CHANNELS: [&str; 4] = ["x", "y", "z", "w"];

/// What a lookup of `quantity` reads, in the words of the tables' names.
fn quantity_name(quantity: Quantity) -> &'static str {
    match quantity {
        Quantity::Albedo => "FGD",
        Quantity::Tir => "TIR",
        Quantity::Gd => "GD",
    }
}

/// Channels as stored: DDS holds 1, 2 or 4.
fn padded(n: usize) -> usize {
    match n {
        0 | 1 => 1,
        2 => 2,
        _ => 4,
    }
}

/// The manifest's texture coordinate of `x` along `axis`, as the CPU's f32 sampler computes it
/// ([`Axis::texture_coordinate_in`]), printed.
pub fn coordinate(axis: &Axis, x: Expr) -> Expr {
    axis.texture_coordinate_in(InShader(x)).0
}

/// The texture coordinate of `x` along node-aligned `axis` of a slice whose first node is texel
/// `origin` of a texture array `extent` texels wide along it
/// ([`crate::formats::slice_array::texture_coordinate_in`]), printed.
fn array_coordinate(axis: &Axis, origin: u32, extent: u32, x: Expr) -> Expr {
    crate::formats::slice_array::texture_coordinate_in(axis, origin, extent as usize, InShader(x)).0
}

/// A shader expression in the arithmetic of an axis's coordinates ([`Arithmetic`]), so that the
/// formulas the CPU computes in f32 are printed from the same code: its constants are those f32
/// values, and its `asinh` and `acos` the helpers' ([`helpers::asinh`], [`helpers::acos`]).
#[derive(Clone)]
pub(super) struct InShader(pub(super) Expr);

macro_rules! in_shader_operator {
    ($trait:ident, $method:ident) => {
        impl std::ops::$trait for InShader {
            type Output = InShader;
            fn $method(self, other: InShader) -> InShader {
                InShader(std::ops::$trait::$method(self.0, other.0))
            }
        }
    };
}
in_shader_operator!(Add, add);
in_shader_operator!(Sub, sub);
in_shader_operator!(Mul, mul);
in_shader_operator!(Div, div);

impl Arithmetic for InShader {
    type Constant = f32;
    fn constant(value: f32) -> Self {
        InShader(float(value))
    }
    fn of(value: f64) -> Self {
        InShader(float(value as f32))
    }
    fn max(self, other: Self) -> Self {
        InShader(self.0.max(other.0))
    }
    fn min(self, other: Self) -> Self {
        InShader(self.0.min(other.0))
    }
    fn clamp(self, lo: Self, hi: Self) -> Self {
        InShader(self.0.clamp(lo.0, hi.0))
    }
    fn sqrt(self) -> Self {
        InShader(self.0.sqrt())
    }
    fn floor(self) -> Self {
        InShader(self.0.floor())
    }
    fn asinh(self) -> Self {
        InShader(func("tmh_asinh", vec![self.0]))
    }
    fn acos(self) -> Self {
        InShader(func("tmh_acos", vec![self.0]))
    }
    type Condition = Expr;
    fn less_than(self, other: Self) -> Expr {
        self.0.lt(other.0)
    }
    fn at_most(self, other: Self) -> Expr {
        self.0.le(other.0)
    }
    fn both(a: Expr, b: Expr) -> Expr {
        a.and(b)
    }
    fn select(condition: Expr, then: Self, otherwise: Self) -> Self {
        InShader(select(condition, then.0, otherwise.0))
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::super::super::{Function, Intrinsic, Op, Stmt};
    use super::super::choosers::{padded, reading_each};
    use super::*;
    use crate::loader::ArrayPlace;
    use crate::model::routes::Routes;
    use crate::shader::scene::shapes;
    use crate::table::Mapping;

    /// A value of the chooser functions' f32 arithmetic.
    #[derive(Debug, Clone, Copy, PartialEq)]
    enum Value {
        F(f32),
        B(bool),
        U(u32),
        /// A read of a texture array: the bits of its coordinates and layer.
        Read([u32; 3]),
    }

    impl Value {
        fn f(self) -> f32 {
            match self {
                Value::F(x) => x,
                _ => panic!("{self:?} where an f32 is read"),
            }
        }
        /// An f32 or a u32 as compared.
        fn number(self) -> f64 {
            match self {
                Value::U(k) => f64::from(k),
                _ => f64::from(self.f()),
            }
        }
        fn b(self) -> bool {
            match self {
                Value::B(b) => b,
                _ => panic!("{self:?} where a bool is read"),
            }
        }
    }

    /// Evaluates a slice read's or a texture coordinate's expression in f32, as a GPU computes it: a chooser of
    /// `functions` it calls is run. A texture read (`tmh_bilinear(tmh_tableN, ...)`) stands for the
    /// slice it reads: it is `N`, the binding.
    fn evaluate(e: &Expr, scope: &HashMap<String, Value>, functions: &[Function]) -> Value {
        let eval = |e: &Expr| evaluate(e, scope, functions);
        match e {
            Expr::Name(n) => scope[n],
            Expr::F32(x) => Value::F(*x),
            Expr::Paren(e) | Expr::Member(e, _) => eval(e),
            Expr::Function(function, args) if function == "tmh_bilinear" => match &args[0] {
                Expr::Name(texture) => Value::F(texture.trim_start_matches("tmh_table").parse::<f32>().unwrap()),
                other => panic!("a texture read of {other:?}"),
            },
            Expr::Function(function, args) if function == "tmh_bilinear_layer" => {
                let bits = |k: usize| eval(&args[k]).f().to_bits();
                Value::Read([bits(1), bits(2), bits(5)])
            }
            Expr::Construct(Ty::I32, args) => eval(&args[0]),
            Expr::U32(k) => Value::U(*k),
            // The axis arithmetic's helper, as the CPU's f32 arithmetic computes it (the helper's
            // own body is the GPU's, which the GPU check runs).
            Expr::Function(function, args) if function == "tmh_asinh" => Value::F(eval(&args[0]).f().asinh()),
            Expr::Function(function, args) => {
                let called = functions.iter().find(|f| &f.name == function).expect("a chooser of the module");
                let mut inner: HashMap<String, Value> =
                    called.params.iter().zip(args).map(|((p, _), a)| (p.clone(), eval(a))).collect();
                run(&called.body, &mut inner, functions).expect("the chooser returns")
            }
            Expr::Call(Builtin::Intrinsic(intrinsic), args) => {
                let x: Vec<f32> = args.iter().map(|a| eval(a).f()).collect();
                Value::F(match intrinsic {
                    Intrinsic::Max => x[0].max(x[1]),
                    Intrinsic::Min => x[0].min(x[1]),
                    Intrinsic::Clamp => x[0].clamp(x[1], x[2]),
                    Intrinsic::Sqrt => x[0].sqrt(),
                    other => panic!("the evaluator reads no {other:?}"),
                })
            }
            Expr::Select { condition, then, otherwise } => {
                if eval(condition).b() {
                    eval(then)
                } else {
                    eval(otherwise)
                }
            }
            Expr::Binary(op, a, b) => {
                let (a, b) = (eval(a), eval(b));
                match op {
                    Op::Add => Value::F(a.f() + b.f()),
                    Op::Sub => Value::F(a.f() - b.f()),
                    Op::Mul => Value::F(a.f() * b.f()),
                    Op::Div => Value::F(a.f() / b.f()),
                    Op::Compare(compare) => Value::B(compare.holds(a.number(), b.number())),
                    Op::And => Value::B(a.b() && b.b()),
                    Op::Or => Value::B(a.b() || b.b()),
                }
            }
            other => panic!("the chooser evaluator reads no {other:?}"),
        }
    }

    /// Runs `body` from `scope`; `Some` of what it returns.
    fn run(body: &[Stmt], scope: &mut HashMap<String, Value>, functions: &[Function]) -> Option<Value> {
        for statement in body {
            match statement {
                Stmt::Let { name, value, .. } | Stmt::Var { name, value: Some(value), .. } => {
                    let v = evaluate(value, scope, functions);
                    scope.insert(name.clone(), v);
                }
                Stmt::Assign(Expr::Name(name), value) => {
                    let v = evaluate(value, scope, functions);
                    scope.insert(name.clone(), v);
                }
                Stmt::If { condition, then, otherwise } => {
                    let branch = if evaluate(condition, scope, functions).b() { then } else { otherwise };
                    if let Some(v) = run(branch, scope, functions) {
                        return Some(v);
                    }
                }
                Stmt::Return(e) => return Some(evaluate(e, scope, functions)),
                Stmt::Comment(_) => {}
                other => panic!("the chooser evaluator runs no {other:?}"),
            }
        }
        None
    }

    /// The texture coordinates the shader prints are the CPU's f32 ones bit for bit, for every
    /// mapping and placement and in a texture array: the printed expression run in f32.
    #[test]
    fn printed_texture_coordinates_are_the_cpus_f32_ones() {
        let mappings = [
            Mapping::Identity,
            Mapping::Sqrt,
            Mapping::SqrtOneMinus,
            Mapping::SqrtEnds,
            Mapping::Asinh { scale: 0.001, centre: 0.0 },
            Mapping::Asinh { scale: 0.05, centre: 0.3 },
            Mapping::AsinhRampBelow { scale: 0.01, centre: 0.2, slope_below: 2.0 },
        ];
        for mapping in mappings {
            for node_aligned in [true, false] {
                let axis = if node_aligned {
                    Axis::node_aligned("x", 0.05, 0.95, 33)
                } else {
                    Axis::cell_centred("x", 0.95, 0.05, 33)
                };
                let axis = axis.unwrap().with_mapping(mapping).unwrap();
                for x in [0.0, 0.05, 0.123456789, 0.3, 0.5001, 0.95, 1.0] {
                    let scope = HashMap::from([("x".to_string(), Value::F(x as f32))]);
                    let printed = evaluate(&coordinate(&axis, name("x")), &scope, &[]).f();
                    let cpu = crate::loader::texture_coordinate(&axis, x);
                    assert_eq!(printed.to_bits(), cpu.to_bits(), "{mapping:?} at {x}: printed {printed}, CPU {cpu}");
                    if node_aligned {
                        let printed = evaluate(&array_coordinate(&axis, 7, 100, name("x")), &scope, &[]).f();
                        let cpu = crate::formats::slice_array::texture_coordinate(&axis, 7, 100, x);
                        assert_eq!(printed.to_bits(), cpu.to_bits(), "{mapping:?} at {x} in an array");
                    }
                }
            }
        }
    }

    /// Lattice node 80 of the slices' alpha axis, `(80/128)^2`, exact in f32 and f64.
    const NODE: f64 = 0.390625;

    /// A slice file over `mu` from `mu_start` to 1 and `alpha` in `alpha`.
    fn slice_file(file: &str, mu_start: f64, alpha: (f64, f64)) -> TableFile {
        TableFile {
            file: file.into(),
            table: file.trim_end_matches(".dds").into(),
            place: None,
            axes: vec![
                Axis::node_aligned("mu", mu_start, 1.0, 154).unwrap(),
                Axis::node_aligned("alpha", alpha.0, alpha.1, 12).unwrap().with_mapping(Mapping::Sqrt).unwrap(),
            ],
            channels: 1,
        }
    }

    /// The file of the slice the scene shader reads among `slices` (those at a lookup's index) at
    /// `(mu, alpha)`, run in f32; `known_alpha` where the generator knows the roughness (an
    /// interface's FGD).
    fn chosen(slices: &[TableFile], mu: f32, alpha: f32, known_alpha: Option<f64>) -> String {
        let routes = Routes::of_tir_slices(Vec::new());
        let mut g = Generator::new(&routes, String::new());
        let alpha_expr = if known_alpha.is_some() { float(alpha) } else { name("alpha") };
        let read = g.slice(slices.iter().map(|s| (s, 0)).collect(), name("mu"), alpha_expr, known_alpha);
        let scope = HashMap::from([("mu".to_string(), Value::F(mu)), ("alpha".to_string(), Value::F(alpha))]);
        let binding = evaluate(&read, &scope, &reading_each(&g.slice_choosers)).f();
        g.textures[binding as usize].file.clone()
    }

    /// Slice `layer` of one texture array, over `mu` from `mu_start` to 1 and `alpha` in `alpha`.
    fn array_slice(layer: u32, mu_start: f64, alpha: (f64, f64)) -> TableFile {
        let place = ArrayPlace { layer, origin: [160 * layer, 12 * layer], layer_extent: [1024, 256], layers: 4 };
        TableFile {
            file: "array.dds".into(),
            table: format!("slice{layer}"),
            place: Some(place),
            ..slice_file("", mu_start, alpha)
        }
    }

    /// Choosers of one, two and four slices of one array are printed alike, the shorter ones
    /// padded to four candidates, so they share one function; each reads the slice its own
    /// candidates choose, and never enters a padding candidate's comparison.
    #[test]
    fn a_padded_chooser_never_chooses_a_padding_candidate() {
        let routes = Routes::of_tir_slices(Vec::new());
        let mut g = Generator::new(&routes, String::new());
        g.slices_through_choosers = true;
        let slices = [
            array_slice(0, 0.701171875, (NODE, 1.0)),
            array_slice(1, 0.701171875, (0.32525634765625, 0.4306640625)),
            array_slice(2, 0.0, (0.1, 0.2)),
            array_slice(3, 0.5, (0.0, 0.05)),
        ];
        let reads: Vec<Expr> = [&slices[..1], &slices[..2], &slices[..]]
            .map(|some| g.slice(some.iter().map(|t| (t, 0)).collect(), name("mu"), name("alpha"), None))
            .into();
        let own = reading_each(&g.slice_choosers);
        let shared = padded(&g.slice_choosers);
        let merged = shapes::share(shared.clone(), "slice choosers", |k| format!("shape{k}"), &mut Vec::new()).unwrap();
        assert_eq!(merged.functions.len(), 1, "the padded choosers are one shape");
        // A padding candidate chosen would return this instead of a read.
        const PADDING_CHOSEN: f32 = -7.0;
        let marked: Vec<Function> = shared
            .into_iter()
            .zip(&g.slice_choosers)
            .map(|(mut function, chooser)| {
                let candidates = function.body.iter_mut().filter_map(|s| match s {
                    Stmt::If { then, .. } => Some(then),
                    _ => None,
                });
                // Candidate k is compared in the (k - 1)th.
                let padding = candidates.skip(chooser.candidates.len() - 1).collect::<Vec<_>>();
                assert_eq!(padding.len(), slices.len() - chooser.candidates.len(), "{}: padded to 4", chooser.name);
                for then in padding {
                    *then = vec![Stmt::Return(float(PADDING_CHOSEN))];
                }
                function
            })
            .collect();
        let below = |x: f64| f32::from_bits((x as f32).to_bits() - 1);
        let mus =
            [0.0, 0.3, 0.5, below(0.701171875), 0.701171875_f64 as f32, 0.723594, 0.9, 1.0, 1.0 + 2.0 * f32::EPSILON];
        let alphas = [
            0.0,
            0.04,
            0.05,
            0.1,
            0.15,
            0.2,
            0.3,
            0.32525634765625_f64 as f32,
            below(NODE),
            NODE as f32,
            0.42,
            0.5,
            1.0,
        ];
        for mu in mus {
            for alpha in alphas {
                let scope = HashMap::from([("mu".to_string(), Value::F(mu)), ("alpha".to_string(), Value::F(alpha))]);
                for read in &reads {
                    let expected = evaluate(read, &scope, &own);
                    assert!(matches!(expected, Value::Read(_)), "{expected:?}");
                    assert_eq!(evaluate(read, &scope, &marked), expected, "{read:?} at mu {mu}, alpha {alpha}");
                }
            }
        }
    }

    #[test]
    fn the_slice_chooser_prefers_a_slice_that_holds_the_lookup_as_the_cpu_evaluator_does() {
        // absorbing-coat-00482 of `scripts/make-library 1000 1 DIR --per-scene 250` (as in
        // `model::folder::tests`): TIR at alpha a rounding below lattice node 80, where another
        // material's slice at the index begins; the material's own slice holds it inside. The
        // printed chooser, run in f32, reads the slice that holds it, in either order.
        let other = slice_file("other.dds", 0.701171875, (NODE, 1.0));
        let own = slice_file("own.dds", 0.701171875, (0.32525634765625, 0.4306640625));
        let below = |ulps: u32| f32::from_bits((NODE as f32).to_bits() - ulps);
        for (slices, first) in [([other.clone(), own.clone()], "other.dds"), ([own, other], "own.dds")] {
            for alpha in [below(1), below(8), (NODE - 5e-6) as f32] {
                assert_eq!(chosen(&slices, 0.723594, alpha, None), "own.dds", "alpha {alpha}");
            }
            // Held by both, or by neither and within the slack of both: the first listed; past
            // the own slice's end, the other slice, which holds it.
            assert_eq!(chosen(&slices, 0.723594, 0.42, None), first);
            assert_eq!(chosen(&slices, 1.0 + 2.0 * f32::EPSILON, 0.42, None), first);
            assert_eq!(chosen(&slices, 0.723594, 0.5, None), "other.dds");
        }
        // An interface's FGD, whose roughness the generator knows: a slice over every mu that
        // holds it is always chosen, and the slices that cannot beat it are left out, but not one
        // whose end merely lies within the slack of it (the other slice, listed first).
        let other = slice_file("other.dds", 0.0, (NODE, 1.0));
        let own = slice_file("own.dds", 0.0, (0.32525634765625, 0.4306640625));
        let slices = [other, own];
        for alpha in [NODE - 1e-6, 0.38] {
            assert_eq!(chosen(&slices, 0.5, alpha as f32, Some(alpha)), "own.dds", "alpha {alpha}");
        }
        assert_eq!(chosen(&slices, 0.5, NODE as f32, Some(NODE)), "other.dds");
        assert_eq!(chosen(&slices, 0.5, 0.42, Some(0.42)), "other.dds");
    }
}
