//! Columns of a log and their order in a file ([`Layout`]).

/// The columns the contract knows, in canonical order.
pub const KNOWN_COLUMNS: [&str; 9] = [
    "t_s",
    "z_m_mm",
    "f_hz",
    "r1_mm",
    "r2_mm",
    "session",
    "valid",
    "r1_ref_mm",
    "r2_ref_mm",
];

/// One column of a log file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Column {
    /// `t_s`
    T,
    /// `z_m_mm`
    Z,
    /// `f_hz`
    F,
    /// `r1_mm`
    R1,
    /// `r2_mm`
    R2,
    /// `session`
    Session,
    /// `valid`
    Valid,
    /// `r1_ref_mm`
    R1Ref,
    /// `r2_ref_mm`
    R2Ref,
    /// Unknown column: index into [`Layout::extra_columns`] / [`crate::LogRow::extra`].
    Extra(usize),
}

impl Column {
    /// The known column of this header name, if it is one.
    pub fn known(name: &str) -> Option<Column> {
        Some(match name {
            "t_s" => Column::T,
            "z_m_mm" => Column::Z,
            "f_hz" => Column::F,
            "r1_mm" => Column::R1,
            "r2_mm" => Column::R2,
            "session" => Column::Session,
            "valid" => Column::Valid,
            "r1_ref_mm" => Column::R1Ref,
            "r2_ref_mm" => Column::R2Ref,
            _ => return None,
        })
    }

    /// The header name of this column (`extra`: the layout's unknown column names).
    pub fn name<'a>(&self, extra: &'a [String]) -> &'a str {
        match self {
            Column::T => "t_s",
            Column::Z => "z_m_mm",
            Column::F => "f_hz",
            Column::R1 => "r1_mm",
            Column::R2 => "r2_mm",
            Column::Session => "session",
            Column::Valid => "valid",
            Column::R1Ref => "r1_ref_mm",
            Column::R2Ref => "r2_ref_mm",
            Column::Extra(i) => &extra[*i],
        }
    }
}

/// The layout of a log: which columns, in which order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// Columns in file order.
    pub columns: Vec<Column>,
    /// Names of the unknown columns (indexed by `Column::Extra`).
    pub extra_columns: Vec<String>,
}

impl Layout {
    /// `t_s,z_m_mm,f_hz,r1_mm,r2_mm`, plus the optional columns asked for, in canonical order.
    pub fn standard(radii: bool, session: bool, valid: bool, refs: bool) -> Layout {
        let mut columns = vec![Column::T, Column::Z, Column::F];
        if radii {
            columns.extend([Column::R1, Column::R2]);
        }
        if session {
            columns.push(Column::Session);
        }
        if valid {
            columns.push(Column::Valid);
        }
        if refs {
            columns.extend([Column::R1Ref, Column::R2Ref]);
        }
        Layout {
            columns,
            extra_columns: Vec::new(),
        }
    }

    /// True when the layout holds this column.
    pub fn has(&self, c: &Column) -> bool {
        self.columns.contains(c)
    }

    /// Add a column at the end if it is not there yet.
    pub fn ensure(&mut self, c: Column) {
        if !self.has(&c) {
            self.columns.push(c);
        }
    }

    /// Add an unknown (extra) column at the end; returns its index for `LogRow::extra`.
    pub fn add_extra(&mut self, name: &str) -> usize {
        if let Some(i) = self.extra_columns.iter().position(|n| n == name) {
            return i;
        }
        self.extra_columns.push(name.to_string());
        let i = self.extra_columns.len() - 1;
        self.columns.push(Column::Extra(i));
        i
    }

    /// Header names in file order.
    pub fn header(&self) -> Vec<&str> {
        self.columns
            .iter()
            .map(|c| c.name(&self.extra_columns))
            .collect()
    }
}
