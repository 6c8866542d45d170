//! The one declarative list behind each plug point (aggregation rule, pre-aggregator, attack,
//! ledger attack, behaviour): [`registry!`] turns a list of `Variant = "name"` lines into the
//! enum, its `ALL` (length counted from the list, never written by hand), `name`, `from_name`,
//! `index` and `COUNT`, and, for plug points that carry data per variant (a rule's quorum),
//! a `spec` from the same line.
//!
//! A line that names its file (`Krum = "krum" in krum => ..`) also declares that file in its
//! domain and dispatches the variant to the type of the variant's name there (`krum::Krum`):
//! the registry then makes a macro (`rule_files!`, named on the enum's line) that hands the
//! lines to the domain's own declaring macro (`contract/rules/mod.rs`, `contract/preagg/`,
//! `byzantine/`, `byzantine/ledger/`), which writes the `mod` items and the one `match` from
//! variant to type, calling the plug point's trait. So a new rule, stage or attack is its file
//! (its type implementing the trait) and its line, nothing else; the domain's macro refuses to
//! compile a line without a file unless it is one of the few it handles by name (`none`,
//! honest robots). `core/tests/registry.rs` checks the other direction: every file in a plug
//! point's folder is registered, so a file whose line is missing fails a test instead of being
//! left out of the build unnoticed.
//!
//! Variants after `; unlisted:` (the plug-in rule) exist, parse and have a name, but are not in
//! `ALL` (which lists the built-in ones).

/// Declares a plug point's enum from its list; see the module documentation.
///
/// ```text
/// registry! {
///     /// The enum's documentation.
///     #[derive(...)]
///     pub enum Kind => Spec, files kind_files {  // `=> Spec` only when lines carry data,
///                                                // `files ..` only when lines name files
///         /// The variant's documentation.
///         Variant = "name" in file => Spec::..,  // `in file`: core/src/<domain>/file.rs
///         ...
///         ; unlisted:                // optional: variants left out of `ALL`
///         Other = "other" in other => Spec::..,
///     }
/// }
/// ```
macro_rules! registry {
    // Lines that name their files: the domain's macro of them, then the enum.
    (
        $(#[$meta:meta])*
        $vis:vis enum $Enum:ident $(=> $Spec:ty)?, files $files:ident {
            $(
                $(#[$vmeta:meta])*
                $Variant:ident = $name:literal $(in $file:ident)? $(=> $spec:expr)?,
            )+
            $( ; unlisted: $(
                $(#[$umeta:meta])*
                $Unlisted:ident = $uname:literal $(in $ufile:ident)? $(=> $uspec:expr)?,
            )+ )?
        }
    ) => {
        registry! {
            @files ($) $Enum $files [
                $( $Variant $(in $file)?, )+ $( $( $Unlisted $(in $ufile)?, )+ )?
            ]
        }
        registry! {
            $(#[$meta])*
            $vis enum $Enum $(=> $Spec)? {
                $( $(#[$vmeta])* $Variant = $name $(=> $spec)?, )+
                $( ; unlisted: $( $(#[$umeta])* $Unlisted = $uname $(=> $uspec)?, )+ )?
            }
        }
    };
    // The macro `$files!(then)` that calls `then! { Enum: Variant in file, Other, .. }` with
    // every line, listed or not, in the registry's order (`$d` is a `$`, which a macro cannot
    // write itself).
    (@files ($d:tt) $Enum:ident $files:ident [ $( $Variant:ident $(in $file:ident)?, )+ ]) => {
        macro_rules! $files {
            ($d then:ident) => {
                $d then! { $Enum: $( $Variant $(in $file)? ),+ }
            };
        }
        pub(crate) use $files;
    };
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
