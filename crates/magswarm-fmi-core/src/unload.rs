//! One-time tables that live until the FMU's library is unloaded, and are freed then.
//!
//! A model whose variable table is built at run time (in a `LazyLock`) has to leak it to get
//! a `&'static` slice; after `dlclose` nothing points at that memory any more and it is lost
//! for the rest of the host's process (valgrind: "definitely lost"). [`leak`] hands out the
//! slice and remembers it; [`release_all`] frees every such table. `export_fmi2!` runs
//! `release_all` from the library's `.fini_array`, i.e. when the loader unloads the FMU (or
//! at process exit), after which no `fmi2*` function of that library can run any more.

use std::sync::Mutex;

struct Leaked {
    ptr: usize,
    len: usize,
    free: unsafe fn(usize, usize),
}

static LEAKED: Mutex<Vec<Leaked>> = Mutex::new(Vec::new());

unsafe fn free_slice<T>(ptr: usize, len: usize) {
    // SAFETY: (ptr, len) came from `Box::<[T]>::into_raw` in `leak` and is freed only here.
    drop(unsafe { Box::from_raw(std::ptr::slice_from_raw_parts_mut(ptr as *mut T, len)) });
}

/// `Vec::leak`, remembered so that [`release_all`] can free it when the library is unloaded.
pub fn leak<T: Send + 'static>(v: Vec<T>) -> &'static [T] {
    let b: Box<[T]> = v.into_boxed_slice();
    let len = b.len();
    let ptr = Box::into_raw(b) as *mut T;
    if let Ok(mut l) = LEAKED.lock() {
        l.push(Leaked {
            ptr: ptr as usize,
            len,
            free: free_slice::<T>,
        });
    }
    // SAFETY: freshly leaked; valid until `release_all`, which runs only when the library
    // is unloaded.
    unsafe { std::slice::from_raw_parts(ptr, len) }
}

/// Free every table handed out by [`leak`].
///
/// # Safety
/// No reference obtained from [`leak`] may be used afterwards: call it only when the library
/// is being unloaded (as `export_fmi2!` does).
pub unsafe fn release_all() {
    let all = match LEAKED.lock() {
        Ok(mut l) => std::mem::take(&mut *l),
        Err(_) => return,
    };
    for l in all {
        // SAFETY: each entry is freed once (taken out of the list above).
        unsafe { (l.free)(l.ptr, l.len) };
    }
}
