//! Duplicate keys in JSON and RON files: `serde_json` and `ron` keep the last of two equal keys
//! without a word (an OpenCV stereo JSON with `M1` twice was read with the second), so the text
//! is walked once before it is read, and a map with a key seen before is refused naming it.
//! (The YAML reader refuses duplicates itself; the XML reader checks repeated elements.)

use std::collections::HashSet;
use std::fmt;

use serde::de::{self, Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};

/// A value walked only to check its maps' keys (nothing is kept).
pub(crate) struct UniqueKeys;

/// A map key as text, whatever its type (JSON strings, RON identifiers, numbers, …).
struct Key(String);

impl<'de> Deserialize<'de> for Key {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Key;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a map key")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Key, E> {
                Ok(Key(v.to_string()))
            }
            fn visit_bool<E: de::Error>(self, v: bool) -> Result<Key, E> {
                Ok(Key(v.to_string()))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Key, E> {
                Ok(Key(v.to_string()))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Key, E> {
                Ok(Key(v.to_string()))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Key, E> {
                Ok(Key(v.to_string()))
            }
            fn visit_char<E: de::Error>(self, v: char) -> Result<Key, E> {
                Ok(Key(v.to_string()))
            }
            fn visit_unit<E: de::Error>(self) -> Result<Key, E> {
                Ok(Key("()".into()))
            }
            // a composite key (RON allows one) is walked for its own maps and named by position
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Key, A::Error> {
                let mut n = 0;
                while seq.next_element::<UniqueKeys>()?.is_some() {
                    n += 1;
                }
                Ok(Key(format!("<a key of {n} items>")))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Key, A::Error> {
                UniqueVisitor.visit_map(map).map(|_| Key("<a map key>".into()))
            }
        }
        d.deserialize_any(V)
    }
}

struct UniqueVisitor;

impl<'de> Visitor<'de> for UniqueVisitor {
    type Value = UniqueKeys;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any value")
    }
    fn visit_bool<E: de::Error>(self, _: bool) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_i64<E: de::Error>(self, _: i64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_u64<E: de::Error>(self, _: u64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_i128<E: de::Error>(self, _: i128) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_u128<E: de::Error>(self, _: u128) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_f64<E: de::Error>(self, _: f64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_char<E: de::Error>(self, _: char) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_str<E: de::Error>(self, _: &str) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_bytes<E: de::Error>(self, _: &[u8]) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_unit<E: de::Error>(self) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_none<E: de::Error>(self) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<UniqueKeys, D::Error> {
        UniqueKeys::deserialize(d)
    }
    fn visit_newtype_struct<D: Deserializer<'de>>(self, d: D) -> Result<UniqueKeys, D::Error> {
        UniqueKeys::deserialize(d)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<UniqueKeys, A::Error> {
        while seq.next_element::<UniqueKeys>()?.is_some() {}
        Ok(UniqueKeys)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<UniqueKeys, A::Error> {
        let mut seen = HashSet::new();
        while let Some(Key(k)) = map.next_key::<Key>()? {
            if !seen.insert(k.clone()) {
                return Err(de::Error::custom(format!(
                    "the key {k:?} appears twice in one map (a reader would keep only the last)"
                )));
            }
            map.next_value::<UniqueKeys>()?;
        }
        Ok(UniqueKeys)
    }
}

impl<'de> Deserialize<'de> for UniqueKeys {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(UniqueVisitor)
    }
}

#[cfg(test)]
mod tests {
    use super::UniqueKeys;

    #[test]
    fn repeated_keys_are_found_at_any_depth_in_json_and_ron() {
        assert!(serde_json::from_str::<UniqueKeys>(r#"{"a": 1, "b": [{"c": 2, "d": 3}]}"#).is_ok());
        let e = serde_json::from_str::<UniqueKeys>(r#"{"a": 1, "b": [{"c": 2, "c": 3}]}"#).err().unwrap();
        assert!(e.to_string().contains("\"c\" appears twice"), "{e}");
        assert!(serde_json::from_str::<UniqueKeys>(r#"{"M1": 1, "M1": 2}"#).is_err());
        assert!(ron::from_str::<UniqueKeys>("(a: 1, b: Some((c: 2)), d: [1, 2], e: X((f: 1)))").is_ok());
        let e = ron::from_str::<UniqueKeys>("(a: 1, b: Some((c: 2, c: 3)))").err().unwrap();
        assert!(e.to_string().contains("\"c\" appears twice"), "{e}");
        assert!(ron::from_str::<UniqueKeys>("(a: 1, a: 2)").is_err());
        assert!(ron::from_str::<UniqueKeys>("{\"k\": 1, \"k\": 2}").is_err());
    }
}
