//! JSON as the `dth` command writes it (`summary.json`, `table41.json`, `ensemble.json`,
//! `workprecision.json`): serde_json, except for numbers that are not finite.
//!
//! JSON has no infinity and no NaN, and serde_json writes them as `null`, which a reader
//! cannot tell from a missing value (`"failure": null`, `"lambda": null`). Here every
//! non-finite `f64` or `f32`, wherever it sits (a field, an element, a map value), is written
//! as a string instead: `"Infinity"`, `"-Infinity"` or `"NaN"`. Those three are what
//! `float(s)` in Python, `Number(s)` in JavaScript and `s.parse::<f64>()` in Rust read back as
//! the same number; `null` keeps meaning "no value". Finite numbers are written as serde_json
//! writes them.
//!
//! ```
//! #[derive(serde::Serialize)]
//! struct Deviation { mean: f64, max: f64, vertices: Option<f64> }
//! let d = Deviation { mean: 1.5, max: f64::INFINITY, vertices: None };
//! let json = dth_examples::json::to_string_pretty(&d)?;
//! assert!(json.contains(r#""mean": 1.5"#));
//! assert!(json.contains(r#""max": "Infinity""#));
//! assert!(json.contains(r#""vertices": null"#));
//! # Ok::<(), serde_json::Error>(())
//! ```

use serde::ser::{self, Serialize, Serializer};

/// `value` as pretty JSON, with non-finite numbers as the strings of [`non_finite`].
pub fn to_string_pretty<T: Serialize + ?Sized>(value: &T) -> serde_json::Result<String> {
    serde_json::to_string_pretty(&Finite(value))
}

/// The string a non-finite `x` is written as (`"Infinity"`, `"-Infinity"`, `"NaN"`); `None`
/// for a finite `x`.
pub fn non_finite(x: f64) -> Option<&'static str> {
    if x.is_nan() {
        Some("NaN")
    } else if x == f64::INFINITY {
        Some("Infinity")
    } else if x == f64::NEG_INFINITY {
        Some("-Infinity")
    } else {
        None
    }
}

/// A value serialized through [`Strings`].
struct Finite<'a, T: ?Sized>(&'a T);

impl<T: Serialize + ?Sized> Serialize for Finite<'_, T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(Strings(serializer))
    }
}

/// A serializer (or one of its compound serializers) that passes everything to the one it
/// wraps, except non-finite numbers, which become strings; what it nests is wrapped again.
struct Strings<S>(S);

/// The forwarding methods of [`Strings`]'s `Serializer` impl that need no change.
macro_rules! forward {
    ($($name:ident($($arg:ident: $ty:ty),*);)*) => {
        $(fn $name(self, $($arg: $ty),*) -> Result<S::Ok, S::Error> {
            self.0.$name($($arg),*)
        })*
    };
}

impl<S: Serializer> Serializer for Strings<S> {
    type Ok = S::Ok;
    type Error = S::Error;
    type SerializeSeq = Strings<S::SerializeSeq>;
    type SerializeTuple = Strings<S::SerializeTuple>;
    type SerializeTupleStruct = Strings<S::SerializeTupleStruct>;
    type SerializeTupleVariant = Strings<S::SerializeTupleVariant>;
    type SerializeMap = Strings<S::SerializeMap>;
    type SerializeStruct = Strings<S::SerializeStruct>;
    type SerializeStructVariant = Strings<S::SerializeStructVariant>;

    forward! {
        serialize_bool(v: bool);
        serialize_i8(v: i8);
        serialize_i16(v: i16);
        serialize_i32(v: i32);
        serialize_i64(v: i64);
        serialize_i128(v: i128);
        serialize_u8(v: u8);
        serialize_u16(v: u16);
        serialize_u32(v: u32);
        serialize_u64(v: u64);
        serialize_u128(v: u128);
        serialize_char(v: char);
        serialize_str(v: &str);
        serialize_bytes(v: &[u8]);
        serialize_none();
        serialize_unit();
        serialize_unit_struct(name: &'static str);
        serialize_unit_variant(name: &'static str, index: u32, variant: &'static str);
    }

    fn serialize_f32(self, v: f32) -> Result<S::Ok, S::Error> {
        match non_finite(f64::from(v)) {
            Some(s) => self.0.serialize_str(s),
            None => self.0.serialize_f32(v),
        }
    }

    fn serialize_f64(self, v: f64) -> Result<S::Ok, S::Error> {
        match non_finite(v) {
            Some(s) => self.0.serialize_str(s),
            None => self.0.serialize_f64(v),
        }
    }

    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<S::Ok, S::Error> {
        self.0.serialize_some(&Finite(value))
    }

    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        name: &'static str,
        value: &T,
    ) -> Result<S::Ok, S::Error> {
        self.0.serialize_newtype_struct(name, &Finite(value))
    }

    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        name: &'static str,
        index: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<S::Ok, S::Error> {
        self.0
            .serialize_newtype_variant(name, index, variant, &Finite(value))
    }

    fn serialize_seq(self, len: Option<usize>) -> Result<Self::SerializeSeq, S::Error> {
        self.0.serialize_seq(len).map(Strings)
    }

    fn serialize_tuple(self, len: usize) -> Result<Self::SerializeTuple, S::Error> {
        self.0.serialize_tuple(len).map(Strings)
    }

    fn serialize_tuple_struct(
        self,
        name: &'static str,
        len: usize,
    ) -> Result<Self::SerializeTupleStruct, S::Error> {
        self.0.serialize_tuple_struct(name, len).map(Strings)
    }

    fn serialize_tuple_variant(
        self,
        name: &'static str,
        index: u32,
        variant: &'static str,
        len: usize,
    ) -> Result<Self::SerializeTupleVariant, S::Error> {
        self.0
            .serialize_tuple_variant(name, index, variant, len)
            .map(Strings)
    }

    fn serialize_map(self, len: Option<usize>) -> Result<Self::SerializeMap, S::Error> {
        self.0.serialize_map(len).map(Strings)
    }

    fn serialize_struct(
        self,
        name: &'static str,
        len: usize,
    ) -> Result<Self::SerializeStruct, S::Error> {
        self.0.serialize_struct(name, len).map(Strings)
    }

    fn serialize_struct_variant(
        self,
        name: &'static str,
        index: u32,
        variant: &'static str,
        len: usize,
    ) -> Result<Self::SerializeStructVariant, S::Error> {
        self.0
            .serialize_struct_variant(name, index, variant, len)
            .map(Strings)
    }

    fn is_human_readable(&self) -> bool {
        self.0.is_human_readable()
    }
}

/// The compound serializers: each element, field, key and value wrapped in [`Finite`].
macro_rules! compound {
    ($($trait:ident :: $method:ident($($key:ident: $key_ty:ty),*);)*) => {
        $(impl<S: ser::$trait> ser::$trait for Strings<S> {
            type Ok = S::Ok;
            type Error = S::Error;

            fn $method<T: Serialize + ?Sized>(
                &mut self,
                $($key: $key_ty,)*
                value: &T,
            ) -> Result<(), S::Error> {
                self.0.$method($($key,)* &Finite(value))
            }

            fn end(self) -> Result<S::Ok, S::Error> {
                self.0.end()
            }
        })*
    };
}

compound! {
    SerializeSeq::serialize_element();
    SerializeTuple::serialize_element();
    SerializeTupleStruct::serialize_field();
    SerializeTupleVariant::serialize_field();
    SerializeStruct::serialize_field(key: &'static str);
    SerializeStructVariant::serialize_field(key: &'static str);
}

impl<S: ser::SerializeMap> ser::SerializeMap for Strings<S> {
    type Ok = S::Ok;
    type Error = S::Error;

    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), S::Error> {
        self.0.serialize_key(&Finite(key))
    }

    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), S::Error> {
        self.0.serialize_value(&Finite(value))
    }

    fn end(self) -> Result<S::Ok, S::Error> {
        self.0.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[derive(serde::Serialize)]
    enum Shape {
        Pair(f64, f32),
        Named { x: f64 },
        Wrapped(f64),
    }

    /// Every place a number can sit: a field, an option, a sequence, a tuple, a map value, a
    /// tuple and a struct variant, a newtype variant; and the three non-finite values, read
    /// back as the numbers they name.
    #[test]
    fn every_non_finite_number_is_a_string_wherever_it_sits() {
        let inf = f64::INFINITY;
        let mut map = BTreeMap::new();
        map.insert("k", -inf);
        let value = (
            Some(inf),
            vec![1.0, f64::NAN, -inf],
            map,
            [Shape::Pair(inf, f32::NAN), Shape::Named { x: -inf }],
            Shape::Wrapped(f64::NAN),
            None::<f64>,
        );
        let json = to_string_pretty(&value).unwrap();
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let expected = serde_json::json!([
            "Infinity",
            [1.0, "NaN", "-Infinity"],
            {"k": "-Infinity"},
            [{"Pair": ["Infinity", "NaN"]}, {"Named": {"x": "-Infinity"}}],
            {"Wrapped": "NaN"},
            null
        ]);
        assert_eq!(v, expected, "{json}");
        for (text, x) in [("Infinity", inf), ("-Infinity", -inf)] {
            assert_eq!(text.parse::<f64>(), Ok(x));
        }
        assert!("NaN".parse::<f64>().is_ok_and(f64::is_nan));
        // Finite numbers as serde_json writes them.
        let finite = (0.1, 1e300, -2.5f32, Some(vec![1u8]), "inf");
        assert_eq!(
            to_string_pretty(&finite).unwrap(),
            serde_json::to_string_pretty(&finite).unwrap()
        );
    }
}
