//! A plug-in writes only in its work folder, where the platform allows it:
//! on Linux by Landlock, the kernel's access control for unprivileged
//! processes (Linux 5.13 and later; the kernel's "Landlock: unprivileged
//! access control", Documentation/userspace-api/landlock.rst). The rule
//! set is built in aeroid's process before the plug-in starts: it handles
//! every right that changes the file system (write, truncate, remove,
//! create, link or rename across folders, as far as the kernel's Landlock
//! version knows them) and grants them beneath the work folder, and the
//! right to write `/dev/null`. The plug-in's process, between fork and
//! exec, sets no-new-privileges and restricts itself to the rule set; its
//! children inherit the restriction. Reading is not restricted: a plug-in
//! needs its interpreter and libraries, and the truth is never in the work
//! folder. Files already open (its stdout and stderr in the work folder)
//! stay writable.
//!
//! Where Landlock is missing (another system, an old kernel, a container
//! that filters the calls) the plug-in runs without it and its estimate's
//! notes say so.

use std::path::Path;

/// The outcome of preparing the sandbox: the rules, or why there are none.
pub(crate) enum Sandbox {
    /// A Landlock rule set to enter in the plug-in's process.
    Landlock(landlock::RuleSet),
    /// No sandbox, and why.
    Unavailable(Unavailable),
}

/// Why a plug-in runs without a sandbox.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum Unavailable {
    /// The kernel has no Landlock (too old, or calls filtered).
    #[error("this kernel has no Landlock ({0})")]
    NoLandlock(std::io::Error),
    /// The kernel refused to create the rule set.
    #[error("Landlock refused a rule set: {0}")]
    RuleSet(std::io::Error),
    /// A folder the rules name cannot be opened.
    #[error("{}: {source}", path.display())]
    Open {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    /// A path that cannot be passed to the kernel.
    #[error("{}: a path with a NUL byte", .0.display())]
    NulByte(std::path::PathBuf),
    /// The kernel refused the rule for a folder.
    #[error("Landlock refused the rule for {}: {source}", path.display())]
    Rule {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    /// A system other than Linux.
    #[cfg(not(target_os = "linux"))]
    #[error("Landlock is Linux's; this system has no sandbox for plug-ins")]
    NotLinux,
}

impl Sandbox {
    /// The rules for a plug-in whose only writable place is `work`.
    pub fn for_work_folder(work: &Path) -> Sandbox {
        match landlock::RuleSet::new(work) {
            Ok(rules) => Sandbox::Landlock(rules),
            Err(reason) => Sandbox::Unavailable(reason),
        }
    }
}

#[cfg(target_os = "linux")]
pub(crate) mod landlock {
    //! The three Landlock system calls and their structures (the kernel's
    //! include/uapi/linux/landlock.h).
    use super::Unavailable;
    use std::ffi::CString;
    use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
    use std::os::unix::ffi::OsStrExt;
    use std::path::Path;

    const CREATE_RULESET_VERSION: u32 = 1;
    const RULE_PATH_BENEATH: libc::c_int = 1;

    const WRITE_FILE: u64 = 1 << 1;
    const REMOVE_DIR: u64 = 1 << 4;
    const REMOVE_FILE: u64 = 1 << 5;
    const MAKE_CHAR: u64 = 1 << 6;
    const MAKE_DIR: u64 = 1 << 7;
    const MAKE_REG: u64 = 1 << 8;
    const MAKE_SOCK: u64 = 1 << 9;
    const MAKE_FIFO: u64 = 1 << 10;
    const MAKE_BLOCK: u64 = 1 << 11;
    const MAKE_SYM: u64 = 1 << 12;
    /// Landlock version 2.
    const REFER: u64 = 1 << 13;
    /// Landlock version 3.
    const TRUNCATE: u64 = 1 << 14;

    #[repr(C)]
    struct RulesetAttr {
        handled_access_fs: u64,
    }

    #[repr(C, packed)]
    struct PathBeneathAttr {
        allowed_access: u64,
        parent_fd: i32,
    }

    /// A Landlock rule set (its file descriptor, closed on drop).
    pub struct RuleSet {
        fd: OwnedFd,
    }

    impl RuleSet {
        /// The rule set of the module header for the work folder `work`;
        /// the reason when the kernel cannot give one.
        pub fn new(work: &Path) -> Result<RuleSet, Unavailable> {
            // SAFETY: the version query takes no pointer (NULL, size 0).
            let version = unsafe {
                libc::syscall(
                    libc::SYS_landlock_create_ruleset,
                    std::ptr::null::<RulesetAttr>(),
                    0usize,
                    CREATE_RULESET_VERSION,
                )
            };
            if version < 1 {
                return Err(Unavailable::NoLandlock(std::io::Error::last_os_error()));
            }
            let mut writes = WRITE_FILE
                | REMOVE_DIR
                | REMOVE_FILE
                | MAKE_CHAR
                | MAKE_DIR
                | MAKE_REG
                | MAKE_SOCK
                | MAKE_FIFO
                | MAKE_BLOCK
                | MAKE_SYM;
            if version >= 2 {
                writes |= REFER;
            }
            if version >= 3 {
                writes |= TRUNCATE;
            }
            let attr = RulesetAttr {
                handled_access_fs: writes,
            };
            // SAFETY: attr is a valid landlock_ruleset_attr of the size given.
            let fd = unsafe {
                libc::syscall(
                    libc::SYS_landlock_create_ruleset,
                    &attr as *const RulesetAttr,
                    std::mem::size_of::<RulesetAttr>(),
                    0u32,
                )
            };
            if fd < 0 {
                return Err(Unavailable::RuleSet(std::io::Error::last_os_error()));
            }
            // SAFETY: the call returned a new file descriptor we own.
            let rules = RuleSet {
                fd: unsafe { OwnedFd::from_raw_fd(fd as i32) },
            };
            rules.allow(work, writes)?;
            rules.allow(Path::new("/dev/null"), WRITE_FILE | (writes & TRUNCATE))?;
            Ok(rules)
        }

        /// Grants `access` beneath `path`.
        fn allow(&self, path: &Path, access: u64) -> Result<(), Unavailable> {
            let name = CString::new(path.as_os_str().as_bytes())
                .map_err(|_| Unavailable::NulByte(path.to_path_buf()))?;
            // SAFETY: name is a NUL-terminated path.
            let raw = unsafe { libc::open(name.as_ptr(), libc::O_PATH | libc::O_CLOEXEC) };
            if raw < 0 {
                return Err(Unavailable::Open {
                    path: path.to_path_buf(),
                    source: std::io::Error::last_os_error(),
                });
            }
            // SAFETY: open returned a new file descriptor we own.
            let parent = unsafe { OwnedFd::from_raw_fd(raw) };
            let attr = PathBeneathAttr {
                allowed_access: access,
                parent_fd: parent.as_raw_fd(),
            };
            // SAFETY: attr is a valid landlock_path_beneath_attr.
            let result = unsafe {
                libc::syscall(
                    libc::SYS_landlock_add_rule,
                    self.fd.as_raw_fd(),
                    RULE_PATH_BENEATH,
                    &attr as *const PathBeneathAttr,
                    0u32,
                )
            };
            if result < 0 {
                return Err(Unavailable::Rule {
                    path: path.to_path_buf(),
                    source: std::io::Error::last_os_error(),
                });
            }
            Ok(())
        }

        /// Restricts the calling process, for its whole future, to the
        /// rules. Only system calls: safe between fork and exec.
        pub fn enter(&self) -> std::io::Result<()> {
            // SAFETY: prctl and the Landlock call take integers only.
            unsafe {
                if libc::prctl(libc::PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                if libc::syscall(libc::SYS_landlock_restrict_self, self.fd.as_raw_fd(), 0u32) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
            }
            Ok(())
        }
    }
}

#[cfg(not(target_os = "linux"))]
pub(crate) mod landlock {
    //! Landlock is Linux's: elsewhere there are no rules.
    use std::path::Path;

    pub struct RuleSet;

    impl RuleSet {
        pub fn new(_work: &Path) -> Result<RuleSet, super::Unavailable> {
            Err(super::Unavailable::NotLinux)
        }

        pub fn enter(&self) -> std::io::Result<()> {
            Ok(())
        }
    }
}
