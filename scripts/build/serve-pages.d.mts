export declare function buildAndServe(opts: { pagesDir: string; port?: number }): Promise<{ url: string; close(): Promise<void> }>;
