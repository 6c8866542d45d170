//! The one declarative list behind each plug point (aggregation rule, pre-aggregator, attack,
//! ledger attack, behaviour): [`registry!`] turns a list of `Variant = "name"` lines into the
//! enum, its `ALL` (length counted from the list, never written by hand), `name`, `from_name`,
//! `index` and `COUNT`, and, for plug points that carry data per variant (a rule's quorum),
//! a `spec` from the same line.
//!
//! So a variant exists exactly when its line does: it cannot be left out of `ALL` (the rule x
//! attack tests and the studies iterate `ALL`), and the dispatch `match` in its domain
//! (`contract/rules/mod.rs`, `byzantine/mod.rs`, ...) fails to compile until it has an arm
//! for the new line. `core/tests/registry.rs` checks the other direction: every file in a
//! plug point's folder is registered.
//!
//! Variants after `; unlisted:` (the plug-in rule) exist, parse and have a name, but are not in
//! `ALL` (which lists the built-in ones).

/// Declares a plug point's enum from its list; see the module documentation.
///
/// ```text
/// registry! {
///     /// The enum's documentation.
///     #[derive(...)]
///     pub enum Kind => Spec {       // `=> Spec` only when lines carry data
///         /// The variant's documentation.
///         Variant = "name" => Spec::..,
///         ...
///         ; unlisted:                // optional: variants left out of `ALL`
///         Other = "other" => Spec::..,
///     }
/// }
/// ```
macro_rules! registry {
    // Lines that carry a spec.
    (
        $(#[$meta:meta])*
        $vis:vis enum $Enum:ident => $Spec:ty {
            $( $(#[$vmeta:meta])* $Variant:ident = $name:literal => $spec:expr, )+
            $( ; unlisted: $(
                $(#[$umeta:meta])* $Unlisted:ident = $uname:literal => $uspec:expr,
            )+ )?
        }
    ) => {
        registry! {
            $(#[$meta])*
            $vis enum $Enum {
                $( $(#[$vmeta])* $Variant = $name, )+
                $( ; unlisted: $( $(#[$umeta])* $Unlisted = $uname, )+ )?
            }
        }

        impl $Enum {
            /// What the variant's line in the registry says beside its name.
            pub const fn spec(self) -> $Spec {
                match self {
                    $( $Enum::$Variant => $spec, )+
                    $( $( $Enum::$Unlisted => $uspec, )+ )?
                }
            }
        }
    };
    // Name-only lines.
    (
        $(#[$meta:meta])*
        $vis:vis enum $Enum:ident {
            $( $(#[$vmeta:meta])* $Variant:ident = $name:literal, )+
            $( ; unlisted: $( $(#[$umeta:meta])* $Unlisted:ident = $uname:literal, )+ )?
        }
    ) => {
        $(#[$meta])*
        $vis enum $Enum {
            $( $(#[$vmeta])* $Variant, )+
            $( $( $(#[$umeta])* $Unlisted, )+ )?
        }

        impl $Enum {
            /// Every listed variant, in the registry's (documentation) order.
            pub const ALL: [$Enum; [$( stringify!($Variant) ),+].len()] = [$( $Enum::$Variant ),+];

            /// The number of variants, listed or not.
            pub const COUNT: usize =
                [$( stringify!($Variant), )+ $( $( stringify!($Unlisted), )+ )?].len();

            /// The name as written in configurations.
            pub const fn name(self) -> &'static str {
                match self {
                    $( $Enum::$Variant => $name, )+
                    $( $( $Enum::$Unlisted => $uname, )+ )?
                }
            }

            /// Looks a variant up by its configuration name (listed or not).
            pub fn from_name(name: &str) -> Option<$Enum> {
                match name {
                    $( $name => Some($Enum::$Variant), )+
                    $( $( $uname => Some($Enum::$Unlisted), )+ )?
                    _ => None,
                }
            }

            /// The variant's place in the registry (listed variants first, in `ALL`'s order).
            pub const fn index(self) -> usize {
                self as usize
            }
        }
    };
}
